"""A corpus of damaged, crafted and foreign recordings, made deterministically from good ones.

`make_corpus(sources, folder)` writes a few hundred files next to each other, in a few seconds:

- truncations at many offsets (inside and between chunks, in the summary, the footer);
- byte flips in the header, in chunks (compressed data, CRC, lengths, compression name, times),
  in message indexes, in the summary, the summary offsets, the data end and the footer;
- absurd length fields (a 2^50-byte attachment, records and strings running past the end);
- crafted metadata (parameters that are not JSON, wrong types, NaN, huge numbers, a start pose
  given as a string, an unknown controller, a newer schema_version, events with bad steps);
- foreign encodings and schemas on the contract's topic names;
- zero-length and non-UTF-8 strings, duplicate and dangling channel and schema ids;
- odd but valid layouts (unchunked, uncompressed, lz4, no summary, out-of-order times).

Each file comes with `intact_messages`: how many messages sit in chunks the damage did not
touch, which `recover` must keep. Byte-level damage is applied to the sources as their writer
made them; crafted files are rebuilt record by record by `build` (a small raw MCAP writer that
can write what no well-behaved writer would).

Run as a script to write a corpus to look at: `python -m tests.helpers.damaged_corpus OUT_DIR GOOD.mcap...`
"""

from __future__ import annotations

import json
import random
import struct
import sys
import zlib
from collections.abc import Callable, Iterable
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import zstandard
from mcap.records import Attachment, Channel, DataEnd, Header, Message, Metadata, Schema
from mcap.stream_reader import StreamReader

MAGIC = b"\x89MCAP0\r\n"
OP_HEADER, OP_FOOTER, OP_SCHEMA, OP_CHANNEL, OP_MESSAGE, OP_CHUNK, OP_MESSAGE_INDEX = 1, 2, 3, 4, 5, 6, 7
OP_CHUNK_INDEX, OP_ATTACHMENT, OP_ATTACHMENT_INDEX, OP_STATISTICS, OP_METADATA = 8, 9, 10, 11, 12
OP_METADATA_INDEX, OP_SUMMARY_OFFSET, OP_DATA_END = 13, 14, 15
HUGE = 1 << 50


@dataclass(frozen=True)
class Damaged:
    path: Path
    family: str  # truncate, flip, length, metadata, foreign, strings, layout
    detail: str
    source: str  # name of the good file it was made from
    intact_messages: int  # messages in chunks the damage left alone (recover keeps at least these)
    byte_damage: bool  # made by editing bytes of a good file (its topics are the good file's)
    sound: bool = False  # a valid file laid out differently: every command must succeed on it
    cameras: bool = False  # its source has camera images


# --- the layout of a file -----------------------------------------------------------------------


@dataclass(frozen=True)
class Rec:
    op: int
    start: int  # offset of the opcode byte
    length: int  # of the body

    @property
    def body(self) -> int:
        return self.start + 9

    @property
    def end(self) -> int:
        return self.start + 9 + self.length


@dataclass
class Layout:
    data: bytes
    records: list[Rec]
    chunk_messages: dict[int, int]  # chunk start offset -> messages inside
    summary_start: int

    def of(self, op: int, in_summary: bool | None = None) -> list[Rec]:
        out = [r for r in self.records if r.op == op]
        if in_summary is not None:
            out = [r for r in out if (self.summary_start > 0 and r.start >= self.summary_start) == in_summary]
        return out

    @property
    def chunks(self) -> list[Rec]:
        return self.of(OP_CHUNK)

    @property
    def total_messages(self) -> int:
        return sum(self.chunk_messages.values())

    def intact_after_damage_at(self, *offsets: int) -> int:
        """Messages in chunks none of `offsets` falls in."""
        return sum(n for c, n in self.chunk_messages.items() if not any(c <= o < self._chunk(c).end for o in offsets))

    def intact_before(self, cut: int) -> int:
        return sum(n for c, n in self.chunk_messages.items() if self._chunk(c).end <= cut)

    def _chunk(self, start: int) -> Rec:
        return next(r for r in self.chunks if r.start == start)


def layout(data: bytes) -> Layout:
    """Every record of a well-formed file, with offsets (summary records included)."""
    pos, records = len(MAGIC), []
    while pos + 9 <= len(data) - len(MAGIC):
        op, length = struct.unpack_from("<BQ", data, pos)
        records.append(Rec(op, pos, length))
        pos += 9 + length
        if op == OP_FOOTER:
            break
    footer = records[-1]
    summary_start = struct.unpack_from("<Q", data, footer.body)[0]
    counts = {}
    for r in records:
        if r.op == OP_CHUNK:
            counts[r.start] = sum(op == OP_MESSAGE for op in _chunk_opcodes(data, r))
    return Layout(data, records, counts, summary_start)


def _chunk_fields(data: bytes, r: Rec) -> dict[str, int]:
    """Offsets of a chunk record's fields."""
    comp_len = struct.unpack_from("<I", data, r.body + 28)[0]
    return {
        "start_time": r.body,
        "end_time": r.body + 8,
        "uncompressed_size": r.body + 16,
        "crc": r.body + 24,
        "compression": r.body + 28,
        "records_length": r.body + 32 + comp_len,
        "records": r.body + 40 + comp_len,
    }


def _chunk_opcodes(data: bytes, r: Rec) -> list[int]:
    """The opcodes of the records inside a chunk."""
    f = _chunk_fields(data, r)
    comp = data[f["compression"] + 4 : f["records_length"]].decode()
    payload = data[f["records"] : r.end]
    raw = zstandard.ZstdDecompressor().decompressobj().decompress(payload) if comp == "zstd" else payload
    ops, pos = [], 0
    while pos < len(raw):
        op, length = struct.unpack_from("<BQ", raw, pos)
        ops.append(op)
        pos += 9 + length
    return ops


# --- a raw MCAP writer that writes whatever it is given -----------------------------------------

Text = str | bytes


def _b(v: Text) -> bytes:
    return v.encode() if isinstance(v, str) else v


def _s(v: Text) -> bytes:
    b = _b(v)
    return struct.pack("<I", len(b)) + b


def _map(d: Iterable[tuple[Text, Text]]) -> bytes:
    body = b"".join(_s(k) + _s(v) for k, v in d)
    return struct.pack("<I", len(body)) + body


def _rec(op: int, body: bytes) -> bytes:
    return struct.pack("<BQ", op, len(body)) + body


@dataclass
class RSchema:
    id: int
    name: Text
    encoding: Text
    data: bytes


@dataclass
class RChannel:
    id: int
    schema_id: int
    topic: Text
    encoding: Text
    metadata: list[tuple[Text, Text]]


@dataclass
class RMessage:
    channel_id: int
    sequence: int
    log_time: int
    publish_time: int
    data: bytes


@dataclass
class RMetadata:
    name: Text
    metadata: list[tuple[Text, Text]]


@dataclass
class RAttachment:
    log_time: int
    create_time: int
    name: Text
    media_type: Text
    data: bytes


Item = RSchema | RChannel | RMessage | RMetadata | RAttachment


@dataclass
class Content:
    """A recording as a list of records in file order, to be rebuilt (and bent) by `build`."""

    profile: Text
    library: Text
    items: list[Item]

    def copy(self) -> Content:
        return Content(self.profile, self.library, [replace(i) for i in self.items])

    def metadata(self, name: str) -> RMetadata:
        return next(i for i in self.items if isinstance(i, RMetadata) and i.name == name)

    def channel(self, topic: str) -> RChannel:
        return next(i for i in self.items if isinstance(i, RChannel) and i.topic == topic)

    def schema(self, sid: int) -> RSchema:
        return next(i for i in self.items if isinstance(i, RSchema) and i.id == sid)

    @property
    def messages(self) -> list[RMessage]:
        return [i for i in self.items if isinstance(i, RMessage)]


def read_content(path: Path) -> Content:
    profile, library, items = "", "", []
    with open(path, "rb") as fh:
        for r in StreamReader(fh).records:
            if isinstance(r, Header):
                profile, library = r.profile, r.library
            elif isinstance(r, Schema):
                items.append(RSchema(r.id, r.name, r.encoding, r.data))
            elif isinstance(r, Channel):
                items.append(RChannel(r.id, r.schema_id, r.topic, r.message_encoding, list(r.metadata.items())))
            elif isinstance(r, Message):
                items.append(RMessage(r.channel_id, r.sequence, r.log_time, r.publish_time, r.data))
            elif isinstance(r, Metadata):
                items.append(RMetadata(r.name, list(r.metadata.items())))
            elif isinstance(r, Attachment):
                items.append(RAttachment(r.log_time, r.create_time, r.name, r.media_type, r.data))
            elif isinstance(r, DataEnd):
                break
    return Content(profile, library, items)


def _item_bytes(i: Item) -> bytes:
    if isinstance(i, RSchema):
        return _rec(OP_SCHEMA, struct.pack("<H", i.id) + _s(i.name) + _s(i.encoding) + _s(i.data))
    if isinstance(i, RChannel):
        return _rec(OP_CHANNEL, struct.pack("<HH", i.id, i.schema_id) + _s(i.topic) + _s(i.encoding) + _map(i.metadata))
    if isinstance(i, RMessage):
        return _rec(OP_MESSAGE, struct.pack("<HIQQ", i.channel_id, i.sequence, i.log_time, i.publish_time) + i.data)
    if isinstance(i, RMetadata):
        return _rec(OP_METADATA, _s(i.name) + _map(i.metadata))
    body = struct.pack("<QQ", i.log_time, i.create_time) + _s(i.name) + _s(i.media_type)
    body += struct.pack("<Q", len(i.data)) + i.data
    return _rec(OP_ATTACHMENT, body + struct.pack("<I", zlib.crc32(body)))


def build(
    c: Content,
    chunk_messages: int = 200,
    compression: str = "zstd",
    chunked: bool = True,
    summary: bool = True,
    message_indexes: bool = True,
) -> bytes:
    """A file holding `c`'s records in order: schemas, channels and messages in chunks of up to
    `chunk_messages` messages, metadata and attachments between chunks; indexes and summary as
    the specification lays them out (nothing is checked: that is the point)."""
    out = bytearray(MAGIC + _rec(OP_HEADER, _s(c.profile) + _s(c.library)))
    chunk_indexes: list[bytes] = []
    meta_indexes: list[bytes] = []
    att_indexes: list[bytes] = []
    pending: list[Item] = []
    schemas: dict[int, RSchema] = {}
    channels: dict[int, RChannel] = {}
    counts: dict[int, int] = {}
    times: list[int] = []

    def flush() -> None:
        if not pending:
            return
        if not chunked:
            for i in pending:
                out.extend(_item_bytes(i))
            pending.clear()
            return
        raw = bytearray()
        index: dict[int, list[tuple[int, int]]] = {}
        for i in pending:
            if isinstance(i, RMessage):
                index.setdefault(i.channel_id, []).append((i.log_time, len(raw)))
            raw.extend(_item_bytes(i))
        msgs = [i.log_time for i in pending if isinstance(i, RMessage)]
        start_t, end_t = (min(msgs), max(msgs)) if msgs else (0, 0)
        if compression == "zstd":
            payload = zstandard.ZstdCompressor().compress(bytes(raw))
        elif compression == "lz4":
            import lz4.frame

            payload = lz4.frame.compress(bytes(raw))
        else:
            payload = bytes(raw)
        chunk_start = len(out)
        body = struct.pack("<QQQI", start_t, end_t, len(raw), zlib.crc32(raw)) + _s(compression)
        out.extend(_rec(OP_CHUNK, body + struct.pack("<Q", len(payload)) + payload))
        chunk_len = len(out) - chunk_start
        offsets = []
        mi_start = len(out)
        if message_indexes:
            for cid, entries in sorted(index.items()):
                offsets.append((cid, len(out)))
                out.extend(
                    _rec(
                        OP_MESSAGE_INDEX,
                        struct.pack("<HI", cid, 16 * len(entries)) + b"".join(struct.pack("<QQ", *e) for e in entries),
                    )
                )
        off_map = struct.pack("<I", 10 * len(offsets)) + b"".join(struct.pack("<HQ", *o) for o in offsets)
        chunk_indexes.append(
            _rec(
                OP_CHUNK_INDEX,
                struct.pack("<QQQQ", start_t, end_t, chunk_start, chunk_len)
                + off_map
                + struct.pack("<Q", len(out) - mi_start)
                + _s(compression)
                + struct.pack("<QQ", len(payload), len(raw)),
            )
        )
        pending.clear()

    for i in c.items:
        if isinstance(i, (RMetadata, RAttachment)):
            flush()
            start = len(out)
            out.extend(_item_bytes(i))
            if isinstance(i, RMetadata):
                meta_indexes.append(_rec(OP_METADATA_INDEX, struct.pack("<QQ", start, len(out) - start) + _s(i.name)))
            else:
                att_indexes.append(
                    _rec(
                        OP_ATTACHMENT_INDEX,
                        struct.pack("<QQQQQ", start, len(out) - start, i.log_time, i.create_time, len(i.data))
                        + _s(i.name)
                        + _s(i.media_type),
                    )
                )
            continue
        if isinstance(i, RSchema):
            schemas.setdefault(i.id, i)
        elif isinstance(i, RChannel):
            channels.setdefault(i.id, i)
        else:
            counts[i.channel_id] = counts.get(i.channel_id, 0) + 1
            times.append(i.log_time)
        pending.append(i)
        if sum(isinstance(p, RMessage) for p in pending) >= chunk_messages:
            flush()
    flush()
    out.extend(_rec(OP_DATA_END, struct.pack("<I", 0)))
    if not summary:
        out.extend(_rec(OP_FOOTER, struct.pack("<QQI", 0, 0, 0)) + MAGIC)
        return bytes(out)
    summary_start = len(out)
    groups: list[tuple[int, bytes]] = [
        (OP_SCHEMA, b"".join(_item_bytes(s) for s in schemas.values())),
        (OP_CHANNEL, b"".join(_item_bytes(ch) for ch in channels.values())),
        (
            OP_STATISTICS,
            _rec(
                OP_STATISTICS,
                struct.pack(
                    "<QHIIIIQQ",
                    len(times),
                    len(schemas),
                    len(channels),
                    len(att_indexes),
                    len(meta_indexes),
                    len(chunk_indexes),
                    min(times, default=0),
                    max(times, default=0),
                )
                + struct.pack("<I", 10 * len(counts))
                + b"".join(struct.pack("<HQ", k, v) for k, v in sorted(counts.items())),
            ),
        ),
        (OP_CHUNK_INDEX, b"".join(chunk_indexes)),
        (OP_ATTACHMENT_INDEX, b"".join(att_indexes)),
        (OP_METADATA_INDEX, b"".join(meta_indexes)),
    ]
    offsets = []
    for op, blob in groups:
        if blob:
            offsets.append(_rec(OP_SUMMARY_OFFSET, struct.pack("<BQQ", op, len(out), len(blob))))
            out.extend(blob)
    summary_offset_start = len(out)
    out.extend(b"".join(offsets))
    footer_head = struct.pack("<BQQQ", OP_FOOTER, 20, summary_start, summary_offset_start)
    crc = zlib.crc32(footer_head, zlib.crc32(bytes(out[summary_start:])))
    out.extend(footer_head + struct.pack("<I", crc) + MAGIC)
    return bytes(out)


# --- the corpus ---------------------------------------------------------------------------------


class _Corpus:
    def __init__(self, folder: Path) -> None:
        self.folder = folder
        self.files: list[Damaged] = []
        self.with_cameras: set[str] = set()

    def add(
        self, source: str, family: str, detail: str, data: bytes, intact: int, byte_damage: bool, sound: bool = False
    ) -> None:
        safe = "".join(ch if ch.isalnum() or ch in "-_" else "-" for ch in detail)[:60]
        path = self.folder / f"{len(self.files):03d}_{source}_{family}_{safe}.mcap"
        path.write_bytes(data)
        self.files.append(
            Damaged(path, family, detail, source, intact, byte_damage, sound, source in self.with_cameras)
        )


def _set(data: bytes, offset: int, fmt: str, value: int) -> bytes:
    b = bytearray(data)
    struct.pack_into(fmt, b, offset, value)
    return bytes(b)


def _flip(data: bytes, offset: int, mask: int) -> bytes:
    b = bytearray(data)
    b[offset] ^= mask or 0xFF
    return bytes(b)


def _byte_damage(corpus: _Corpus, name: str, data: bytes, rng: random.Random) -> None:
    lay = layout(data)
    end = len(data)
    chunks, n = lay.chunks, len(lay.chunks)

    def add(family: str, detail: str, damaged: bytes, intact: int) -> None:
        corpus.add(name, family, detail, damaged, intact, True)

    # truncations: at the structure's edges, then anywhere
    structural = {"magic": 8, "after header": lay.records[0].end, "last byte": end - 1, "no magic": end - 8}
    for k, c in enumerate(chunks):
        structural[f"chunk {k} start"] = c.start
        structural[f"chunk {k} middle"] = c.start + c.length // 2
        structural[f"chunk {k} end"] = c.end
    mi = lay.of(OP_MESSAGE_INDEX)
    if mi:
        structural["inside a message index"] = mi[0].start + 5
    structural["before data end"] = lay.of(OP_DATA_END)[0].start
    structural["after data end"] = lay.of(OP_DATA_END)[0].end
    structural["inside summary"] = (lay.summary_start + end) // 2
    structural["inside footer"] = lay.of(OP_FOOTER)[0].start + 10
    for label, cut in structural.items():
        add("truncate", f"{label} @{cut}", data[:cut], lay.intact_before(cut))
    for cut in sorted(rng.sample(range(9, end), 14)):
        add("truncate", f"@{cut}", data[:cut], lay.intact_before(cut))

    def flip(family: str, detail: str, offset: int, mask: int | None = None) -> None:
        mask = mask if mask is not None else rng.randrange(1, 256)
        add(family, f"{detail} @{offset}", _flip(data, offset, mask), lay.intact_after_damage_at(offset))

    def setf(detail: str, offset: int, fmt: str, value: int) -> None:
        add("length", f"{detail} @{offset}", _set(data, offset, fmt, value), lay.intact_after_damage_at(offset))

    # byte flips
    header = lay.records[0]
    flip("flip", "header magic", rng.randrange(0, 8))
    flip("flip", "header length", header.start + 1 + rng.randrange(0, 8))
    flip("flip", "header profile", header.body + 4, 0x80)
    library_length_at = header.body + 4 + struct.unpack_from("<I", data, header.body)[0]
    flip("flip", "header library length", library_length_at + rng.randrange(0, 4), 0x40)
    for k in rng.sample(range(n), min(n, 3)):
        c = chunks[k]
        f = _chunk_fields(data, c)
        flip("flip", f"chunk {k} compressed data", rng.randrange(f["records"], c.end))
        flip("flip", f"chunk {k} zstd frame header", f["records"] + rng.randrange(0, 6))
    c = chunks[rng.randrange(n)]
    f = _chunk_fields(data, c)
    flip("flip", "chunk crc", f["crc"] + rng.randrange(4))
    flip("flip", "chunk uncompressed size", f["uncompressed_size"], 0x01)
    flip("flip", "chunk uncompressed size high", f["uncompressed_size"] + 3, 0x10)
    flip("flip", "chunk records length", f["records_length"] + 1)
    flip("flip", "chunk record length", c.start + 1 + rng.randrange(0, 3))
    flip("flip", "chunk compression name", f["compression"] + 4 + rng.randrange(0, 4), 0x20)
    flip("flip", "chunk start time", f["start_time"] + 4)
    flip("flip", "chunk opcode", c.start, 0x0A)
    for r in rng.sample(mi, min(len(mi), 4)):
        flip("flip", "message index entry", r.body + 6 + rng.randrange(0, max(1, r.length - 6)))
    if mi:
        flip("flip", "message index length", mi[-1].start + 1 + rng.randrange(0, 4))
        flip("flip", "message index opcode", mi[0].start, 0x0F)
    for r in lay.of(OP_METADATA)[:1] + lay.of(OP_ATTACHMENT)[:1]:
        flip("flip", f"op {r.op} body", r.body + rng.randrange(0, r.length))
    for op in (OP_SCHEMA, OP_CHANNEL, OP_STATISTICS, OP_CHUNK_INDEX, OP_ATTACHMENT_INDEX, OP_METADATA_INDEX):
        recs = lay.of(op, in_summary=True)
        if recs:
            r = recs[rng.randrange(len(recs))]
            flip("flip", f"summary op {op}", r.body + rng.randrange(0, r.length))
    channel_topics = lay.of(OP_CHANNEL, in_summary=True)
    if channel_topics:  # a topic name's bytes, in the summary's copy: not UTF-8, then another letter
        flip("flip", "summary topic name", channel_topics[0].body + 4 + 4 + 2, 0x80)
        flip("flip", "summary topic letter", channel_topics[-1].body + 4 + 4 + 3, 0x01)
    so = lay.of(OP_SUMMARY_OFFSET)
    if so:
        flip("flip", "summary offset", so[0].body + 1 + rng.randrange(0, 16))
    de = lay.of(OP_DATA_END)[0]
    flip("flip", "data end", de.start + rng.randrange(0, 13))
    footer = lay.of(OP_FOOTER)[0]
    flip("flip", "footer summary start", footer.body + rng.randrange(0, 4))
    flip("flip", "footer summary offset start", footer.body + 8 + rng.randrange(0, 4))
    flip("flip", "footer crc", footer.body + 16 + rng.randrange(0, 4))
    flip("flip", "trailing magic", end - 1 - rng.randrange(0, 8))

    # absurd length fields
    for r in lay.of(OP_ATTACHMENT)[:1]:
        name_len = struct.unpack_from("<I", data, r.body + 16)[0]
        media_len = struct.unpack_from("<I", data, r.body + 20 + name_len)[0]
        setf("attachment data length 2^50", r.body + 24 + name_len + media_len, "<Q", HUGE)
        setf("attachment record length 2^50", r.start + 1, "<Q", HUGE)
        setf("attachment name length 2^32-1", r.body + 16, "<I", 0xFFFFFFFF)
    for r in lay.of(OP_METADATA)[:1]:
        setf("metadata record length 2^62", r.start + 1, "<Q", 1 << 62)
        name_len = struct.unpack_from("<I", data, r.body)[0]
        setf("metadata map length past the end", r.body + 4 + name_len, "<I", 0x7FFFFFFF)
    setf("header library length 2^32-1", library_length_at, "<I", 0xFFFFFFFF)
    c = chunks[min(1, n - 1)]
    f = _chunk_fields(data, c)
    setf("chunk record length past the end", c.start + 1, "<Q", end)
    setf("chunk record length 2^63", c.start + 1, "<Q", 1 << 63)
    setf("chunk records length 2^50", f["records_length"], "<Q", HUGE)
    setf("chunk uncompressed size 2^50", f["uncompressed_size"], "<Q", HUGE)
    setf("chunk compression name length 2^31", f["compression"], "<I", 1 << 31)
    if mi:
        setf("message index length 2^40", mi[0].start + 1, "<Q", 1 << 40)
        setf("message index array length 2^31", mi[0].body + 2, "<I", 1 << 31)
    for r in lay.of(OP_CHUNK_INDEX)[:1]:
        setf("chunk index chunk length 2^50", r.body + 24, "<Q", HUGE)
        setf("chunk index chunk offset past the end", r.body + 16, "<Q", end + 1000)
    for r in lay.of(OP_ATTACHMENT_INDEX)[:1]:
        setf("attachment index offset past the end", r.body, "<Q", end * 3)
    setf("footer summary start past the end", footer.body, "<Q", end * 2)
    setf("footer summary start 2^63", footer.body, "<Q", 1 << 63)


def _crafted(corpus: _Corpus, name: str, good: Content, with_cameras: bool) -> None:
    total = len(good.messages)

    def add(family: str, detail: str, content: Content, sound: bool = False, **kw: Any) -> None:
        corpus.add(name, family, detail, build(content, **kw), len(content.messages) if sound else 0, False, sound)

    def with_params(detail: str, edit: Callable[[dict], Any]) -> None:
        c = good.copy()
        md = c.metadata("quadsim")
        entries = dict(md.metadata)
        params = json.loads(entries["parameters"])
        result = edit(params)
        text = result if isinstance(result, str) else json.dumps(params if result is None else result)
        md.metadata = [(k, text if k == "parameters" else v) for k, v in entries.items()]
        add("metadata", detail, c)

    def set_path(path: str, value: Any) -> Callable[[dict], None]:
        def edit(p: dict) -> None:
            *parents, last = path.split(".")
            for key in parents:
                p = p.setdefault(key, {}) if isinstance(p, dict) else p
            p[last] = value

        return edit

    # unmodified, as rebuilt: must read exactly as the original
    add("layout", "rebuilt unchanged", good.copy(), sound=True)
    if not with_cameras:
        add("layout", "small chunks", good.copy(), sound=True, chunk_messages=40)
        add("layout", "uncompressed chunks", good.copy(), sound=True, compression="")
        add("layout", "lz4 chunks", good.copy(), sound=True, compression="lz4")
        add("layout", "unchunked", good.copy(), sound=True, chunked=False)
        add("layout", "no summary", good.copy(), sound=True, summary=False)
        add("layout", "no message indexes", good.copy(), sound=True, message_indexes=False)

    with_params("parameters not JSON", lambda p: "{not json")
    with_params("parameters a JSON list", lambda p: "[1, 2, 3]")
    with_params("parameters JSON null", lambda p: "null")
    with_params("parameters deeply nested", lambda p: "[" * 100000 + "]" * 100000)
    with_params("parameters empty", lambda p: "")
    if with_cameras:
        with_params("camera width huge", lambda p: p["cameras"][0].__setitem__("width_px", 10**12))
        with_params("cameras not a list", set_path("cameras", "front"))
        return
    with_params("physics_hz a string", set_path("config.rates.physics_hz", "fast"))
    with_params("physics_hz NaN", set_path("config.rates.physics_hz", float("nan")))
    with_params("physics_hz huge", set_path("config.rates.physics_hz", 10**30))
    with_params("physics_hz 480", set_path("config.rates.physics_hz", 480))
    with_params("physics_hz 1 million", set_path("config.rates.physics_hz", 1_000_000))
    with_params("state_hz zero", set_path("config.rates.state_hz", 0))
    with_params("mass NaN", set_path("vehicle.mass_kg", float("nan")))
    with_params("mass infinite", set_path("vehicle.mass_kg", float("inf")))
    with_params("mass 1e308", set_path("vehicle.mass_kg", 1e308))
    with_params("start pose a string", set_path("config.start", "over there"))
    with_params("start x a string", set_path("config.start.x_m", "1.0"))
    with_params("start x 1e300", set_path("config.start.x_m", 1e300))
    with_params("start yaw NaN", set_path("config.start.yaw_rad", float("nan")))
    with_params("unknown controller", set_path("controller.name", "pid-deluxe"))
    with_params("controller config unknown", set_path("config.controller", 7))
    with_params("gain NaN", lambda p: p["controller"].setdefault("gains", {}).__setitem__("kp", float("nan")))
    with_params("gain unknown name", lambda p: p["controller"].setdefault("gains", {}).__setitem__("warp", 1.0))
    with_params("gains a list", set_path("controller.gains", [1, 2]))
    with_params("newer schema_version", set_path("schema_version", 99))
    with_params("schema_version a string", set_path("schema_version", "2"))
    with_params("z_mode unknown", set_path("config.z_mode", "sideways"))
    with_params("command timeout negative", set_path("config.command_timeout_s", -1.0))
    with_params("urdf name empty", set_path("vehicle.urdf", ""))
    with_params("urdf name a path", set_path("vehicle.urdf", "../../../etc/passwd"))
    with_params("urdf name a number", set_path("vehicle.urdf", 12))
    with_params("world path NUL", set_path("config.world", "a\0b.toml"))
    with_params("start_step huge", set_path("start_step", 10**18))
    with_params("driver a string", set_path("driver", "keyboard"))
    with_params("no config", lambda p: {k: v for k, v in p.items() if k != "config"})

    # the metadata records themselves
    c = good.copy()
    c.items = [i for i in c.items if not (isinstance(i, RMetadata) and i.name == "quadsim")]
    add("metadata", "no quadsim metadata", c)
    c = good.copy()
    c.metadata("quadsim").metadata = []
    add("metadata", "empty quadsim metadata", c)
    c = good.copy()
    c.items.insert(1, RMetadata("quadsim", [("parameters", "{}")]))
    add("metadata", "two quadsim metadata records", c)

    # events: z-mode switches with bad steps, kinds and values
    for label, event in [
        ("good", [("step", "120"), ("kind", "z_mode"), ("value", "height")]),
        ("step not a number", [("step", "abc"), ("kind", "z_mode"), ("value", "height")]),
        ("step negative", [("step", "-5"), ("kind", "z_mode"), ("value", "height")]),
        ("step huge", [("step", str(10**30)), ("kind", "z_mode"), ("value", "velocity")]),
        ("step float", [("step", "1e3"), ("kind", "z_mode"), ("value", "height")]),
        ("value unknown", [("step", "60"), ("kind", "z_mode"), ("value", "sideways")]),
        ("kind unknown", [("step", "60"), ("kind", "warp"), ("value", "9")]),
        ("fields missing", [("step", "60")]),
    ]:
        c = good.copy()
        c.items.append(RMetadata("quadsim_event", event))
        add("metadata", f"event {label}", c)

    # attachments the vehicle is rebuilt from
    for label, edit in [
        ("urdf not XML", lambda a: a.name.endswith(".urdf") and setattr(a, "data", b"<robot><link")),
        ("urdf empty", lambda a: a.name.endswith(".urdf") and setattr(a, "data", b"")),
        ("params not TOML", lambda a: a.name.endswith(".params.toml") and setattr(a, "data", b"mass = = 3\n\xff")),
        ("world not TOML", lambda a: a.name == "default.toml" and setattr(a, "data", b"[floor\nsize=")),
        ("attachment named empty", lambda a: a.name.endswith(".urdf") and setattr(a, "name", "")),
        ("attachment name a path", lambda a: a.name.endswith(".urdf") and setattr(a, "name", "../x.urdf")),
        ("attachment name too long", lambda a: a.name == "default.toml" and setattr(a, "name", "w" * 300 + ".toml")),
    ]:
        c = good.copy()
        for i in c.items:
            if isinstance(i, RAttachment):
                edit(i)
        add("metadata", label, c)
    c = good.copy()
    c.items = [i for i in c.items if not isinstance(i, RAttachment)]
    add("metadata", "no attachments", c)

    # foreign encodings and schemas on the contract's topic names
    pose = good.channel("/quad/pose")
    twist = good.channel("/quad_cmd_twist")
    for label, topic, edit in [
        ("pose as json", pose, lambda ch, s: setattr(ch, "encoding", "json")),
        ("pose as protobuf", pose, lambda ch, s: setattr(ch, "encoding", "protobuf")),
        ("pose schema Twist", pose, lambda ch, s: setattr(s, "name", "geometry_msgs/msg/Twist")),
        ("pose schema unknown type", pose, lambda ch, s: setattr(s, "name", "acme_msgs/msg/Pose")),
        ("pose schema jsonschema", pose, lambda ch, s: setattr(s, "encoding", "jsonschema")),
        ("pose no schema", pose, lambda ch, s: setattr(ch, "schema_id", 0)),
        ("twist as json", twist, lambda ch, s: setattr(ch, "encoding", "json")),
        ("twist schema Pose", twist, lambda ch, s: setattr(s, "name", "geometry_msgs/msg/PoseStamped")),
    ]:
        c = good.copy()
        ch = c.channel(topic.topic)
        s = c.schema(ch.schema_id)
        if "schema" in label and "no schema" not in label:  # a schema of its own, so others keep theirs
            s = replace(s, id=max(i.id for i in c.items if isinstance(i, RSchema)) + 1)
            c.items.insert(c.items.index(ch), s)
            ch.schema_id = s.id
        edit(ch, s)
        if "json" in label and "schema" not in label:
            for m in c.messages:
                if m.channel_id == ch.id:
                    m.data = b'{"x": 1}'
        add("foreign", label, c)
    for label, data_of in [
        ("pose messages random bytes", lambda m, r: r.randbytes(len(m.data))),
        ("pose messages empty", lambda m, r: b""),
        ("pose messages cut in half", lambda m, r: m.data[: len(m.data) // 2]),
        ("twist messages 3 bytes", lambda m, r: b"\x00\x01\x00"),
        ("thrusts sequence length 2^31", None),
    ]:
        c = good.copy()
        r = random.Random(label)
        if data_of is None:
            cid = c.channel("/quad/rotor_thrusts").id
            for m in c.messages:
                if m.channel_id == cid:
                    m.data = m.data[:4] + struct.pack("<I", 1 << 31) + m.data[8:]
        else:
            cid = (pose if "pose" in label else twist).id
            for m in c.messages:
                if m.channel_id == cid:
                    m.data = data_of(m, r)
        add("foreign", label, c)
    c = good.copy()  # someone else's file on our topic names, no metadata
    c.items = [i for i in c.items if not isinstance(i, (RMetadata, RAttachment))]
    c.profile, c.library = "", "someone else"
    add("foreign", "contract topics from another program", c)

    # times
    c = good.copy()
    c.messages[-1].log_time = (1 << 64) - 1
    add("layout", "last message at 2^64-1 ns", c)
    c = good.copy()
    pose_msgs = [m for m in c.messages if m.channel_id == pose.id]
    pose_msgs[-1].log_time = 10**18
    add("layout", "last pose 31 years later", c)
    c = good.copy()
    c.items.reverse()
    add("layout", "records in reverse order", c)
    c = good.copy()
    c.items = [i for i in c.items if not isinstance(i, RMessage)]
    add("layout", "no messages", c)
    c = good.copy()
    c.items = [i for i in c.items if not isinstance(i, (RSchema, RChannel))]
    add("layout", "no schemas or channels", c)

    # strings and ids
    for label, edit in [
        ("topic empty", lambda ch: setattr(ch, "topic", "")),
        ("topic not UTF-8", lambda ch: setattr(ch, "topic", b"/quad/\xff\xfepose")),
        ("encoding not UTF-8", lambda ch: setattr(ch, "encoding", b"cd\xc3")),
        ("channel metadata not UTF-8", lambda ch: setattr(ch, "metadata", [(b"\xff", b"\xfe")])),
    ]:
        c = good.copy()
        edit(c.channel("/quad/pose"))
        add("strings", label, c)
    c = good.copy()
    c.schema(pose.schema_id).name = b"geometry_msgs/msg/\xffPoseStamped"
    add("strings", "schema name not UTF-8", c)
    c = good.copy()
    c.metadata("quadsim").metadata = [(b"param\xffeters", b"{}"), ("parameters", b"\xff\xfe{}")]
    add("strings", "metadata not UTF-8", c)
    c = good.copy()
    next(i for i in c.items if isinstance(i, RAttachment)).name = b"quadsim_x\xff.urdf"
    add("strings", "attachment name not UTF-8", c)
    c = good.copy()
    c.library, c.profile = b"\xff\xfe", b""
    add("strings", "header not UTF-8", c)
    c = good.copy()  # a second definition of the pose channel's id, for another topic, midway
    half = c.items.index(c.messages[len(c.messages) // 2])
    c.items.insert(half, RChannel(pose.id, pose.schema_id, "/elsewhere", "cdr", []))
    add("strings", "channel id redefined midway", c)
    c = good.copy()
    c.items.insert(half, replace(c.channel("/quad/pose")))
    add("strings", "channel defined twice identically", c)
    c = good.copy()
    c.items.insert(half, RSchema(pose.schema_id, "std_msgs/msg/String", "ros2msg", b"string data"))
    add("strings", "schema id redefined midway", c)
    c = good.copy()
    c.messages[5].channel_id = 999
    c.messages[6].channel_id = 0
    add("strings", "messages on unknown channels", c)
    c = good.copy()
    c.channel("/quad/pose").schema_id = 777
    add("strings", "channel with unknown schema", c)
    del total


def make_corpus(sources: list[tuple[str, Path]], folder: Path, seed: int = 9) -> list[Damaged]:
    """Write the corpus into `folder` (which must exist); `sources` are (short name, good file),
    the first one with cameras, the second without."""
    corpus = _Corpus(folder)
    corpus.with_cameras.add(sources[0][0])
    rng = random.Random(seed)
    for index, (name, path) in enumerate(sources):
        data = path.read_bytes()
        _byte_damage(corpus, name, data, rng)
        _crafted(corpus, name, read_content(path), with_cameras=index == 0)
    # a few made of several files
    a, b = (p.read_bytes() for _, p in sources[:2])
    last = sources[-1][0]
    corpus.add(last, "layout", "two files concatenated", b + a, 0, False)
    corpus.add(last, "layout", "garbage after the end", b + rng.randbytes(3000), layout(b).total_messages, True)
    corpus.add(
        last,
        "layout",
        "garbage instead of the summary",
        b[: layout(b).summary_start] + rng.randbytes(500),
        layout(b).total_messages,
        True,
    )
    corpus.add(last, "layout", "magic then garbage", MAGIC + rng.randbytes(4000), 0, False)
    corpus.add(last, "layout", "header then zeros", b[: layout(b).records[0].end] + bytes(20000), 0, False)
    return corpus.files


def main(argv: list[str]) -> int:
    if len(argv) < 3:
        print(__doc__.strip().splitlines()[-1])
        return 2
    out = Path(argv[0])
    out.mkdir(parents=True, exist_ok=True)
    files = make_corpus([(Path(p).stem, Path(p)) for p in argv[1:]], out)
    print(f"{len(files)} files in {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
