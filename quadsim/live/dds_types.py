"""ROS 2 message types as Eclipse Cyclone DDS IDL types, built from rosbags' typestore (the
contract's reference for every type, tf2_msgs and visualization_msgs included).

A ROS 2 type `pkg/msg/Type` is the DDS type `pkg::msg::dds_::Type_` on the wire; its fields are
the message's, in order, with ROS 2's IDL mapping (byte -> octet, char -> uint8).
"""

from __future__ import annotations

from functools import cache
from importlib import import_module
from typing import Any

from quadsim.recording.contract import typestore

#: the base types whose Cyclone DDS name is not their ROS 2 name (ROS 2's IDL mapping: a char is a
#: uint8); the rest, bool and string aside, are named alike (byte: octet)
_CYCLONE_NAMES = {"char": "uint8"}


def dds_type_name(type_name: str) -> str:
    """`geometry_msgs/msg/Twist` -> `geometry_msgs::msg::dds_::Twist_` (as rmw implementations name it)."""
    package, kind, name = type_name.split("/")
    return f"{package}::{kind}::dds_::{name}_"


def _field_type(node: tuple[Any, Any]) -> Any:
    from rosbags.interfaces import Nodetype

    types: Any = import_module("cyclonedds.idl.types")  # its generic aliases are not typed as such

    kind, detail = node
    if kind == Nodetype.BASE:
        name, bound = detail
        if name == "string":
            return types.bounded_str[bound] if bound else str
        if name == "bool":
            return bool
        return getattr(types, _CYCLONE_NAMES.get(name, name))
    if kind == Nodetype.NAME:
        return idl_type(detail)
    element, size = detail
    if kind == Nodetype.ARRAY:
        return types.array[_field_type(element), size]
    return types.sequence[_field_type(element), size] if size else types.sequence[_field_type(element)]


@cache
def idl_type(type_name: str) -> Any:
    """The Cyclone DDS IdlStruct class of a ROS 2 message type, built once."""
    from cyclonedds.idl import make_idl_struct

    _consts, fields = typestore().fielddefs[type_name]
    members = {name: _field_type(node) for name, node in fields}
    return make_idl_struct(type_name.replace("/", "_"), dds_type_name(type_name), members)
