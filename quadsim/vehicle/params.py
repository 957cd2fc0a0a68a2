"""Vehicle parameters: read once from the URDF (mass, inertia, rotor and camera links) and the
parameter file beside it (rotor coefficients, limits, aerodynamics, IMU noise, range finder and
LiDAR), validated, frozen.
Every table of the parameter file refuses a key it does not know."""

from __future__ import annotations

import enum
import math
import re
import xml.etree.ElementTree as ET
from dataclasses import MISSING, dataclass, field, fields
from pathlib import Path
from typing import Any

from quadsim.assets import asset_path
from quadsim.core.kinematics import IDENTITY, Mat3, Vec3, mat_mul, matrix_from_rpy, rotate, transpose
from quadsim.core.toml_files import read_toml, refuse_unknown_keys
from quadsim.errors import ConfigError
from quadsim.vehicle.meshes import pybullet_urdf

#: The airframes the project ships, by the names `--vehicle` takes (each URDF has its
#: NAME.params.toml beside it).
SHIPPED_VEHICLES: dict[str, Path] = {
    "quad": asset_path("urdf", "quadsim_x.urdf"),
    "hexa": asset_path("urdf", "quadsim_hexa.urdf"),
    "crazyflie": asset_path("urdf", "crazyflie.urdf"),
}
#: The vehicle flown when no other is asked for.
DEFAULT_VEHICLE = "quad"
DEFAULT_URDF = SHIPPED_VEHICLES[DEFAULT_VEHICLE]


class Spin(enum.Enum):
    """Rotor spin seen from above. A CCW rotor pushes the body clockwise (negative yaw)."""

    CCW = "ccw"
    CW = "cw"

    @property
    def sign(self) -> int:
        return 1 if self is Spin.CCW else -1


@dataclass(frozen=True)
class AeroParams:
    """The [aero] section of a vehicle's parameter file (units in the names)."""

    body_drag_linear_ns_per_m: Vec3  # per base_link axis (x forward, y left, z up)
    body_drag_quadratic_ns2_per_m2: Vec3  # per base_link axis: 1/2 rho C_d A
    rotor_drag_ns_per_m_rad: float  # per rotor, per rad/s of rotor speed, per m/s of in-plane airspeed
    rotor_axial_drag_ns_per_m_rad: float  # the same along the rotor axis (body z)
    rotor_radius_m: float
    ground_effect: bool
    ground_effect_max_ratio: float  # cap on T_ige / T_oge (Cheeseman-Bennett diverges at z = R/4)


@dataclass(frozen=True)
class ContactParams:
    """The [contact] section: how the frame meets the world. PyBullet multiplies the two bodies'
    figures of a contact; the world's bodies have restitution 1, so the frame's is the contact's,
    and the floor's friction (the world file's) multiplies the frame's."""

    restitution: float  # rebound speed over impact speed, normal to the contact
    lateral_friction: float  # Coulomb friction coefficient


@dataclass(frozen=True)
class RotorSpec:
    link_name: str
    position_m: Vec3  # rotor origin relative to the vehicle's centre of mass, in base_link
    spin: Spin


@dataclass(frozen=True)
class CameraMount:
    """Where a camera link sits on the body: pose relative to the base_link origin.

    The link's x axis is the viewing direction and its z axis the image's up."""

    link_name: str
    position_m: Vec3
    rotation: Mat3  # base_link <- camera link


@dataclass(frozen=True)
class LinkFrame:
    """Where a URDF link's frame sits on the body: its pose relative to the base_link origin
    (what /tf_static says, so viewers place the model's parts)."""

    link_name: str
    position_m: Vec3
    rotation: Mat3  # base_link <- link


@dataclass(frozen=True)
class CommandLimits:
    max_horizontal_speed_mps: float
    max_climb_rate_mps: float
    max_descent_rate_mps: float
    max_yaw_rate_radps: float
    min_altitude_m: float
    max_altitude_m: float


@dataclass(frozen=True)
class ImuNoiseParams:
    """The [imu] section: white noise densities and bias random walks of the IMU (continuous
    time; a sensor sampled at f Hz has white noise of standard deviation density * sqrt(f))."""

    gyro_noise_density_radps_per_rthz: float
    gyro_bias_random_walk_radps2_per_rthz: float
    accel_noise_density_mps2_per_rthz: float
    accel_bias_random_walk_mps3_per_rthz: float


class RadiationType(enum.Enum):
    """sensor_msgs/Range's radiation_type: what the range finder measures with."""

    ULTRASOUND = "ultrasound"  # 0 on the wire
    INFRARED = "infrared"  # 1 on the wire (a time-of-flight laser such as the VL53L1x)

    @property
    def wire(self) -> int:
        return 0 if self is RadiationType.ULTRASOUND else 1


@dataclass(frozen=True)
class RangeParams:
    """The [range] table: a single-beam range finder (sensor_msgs/Range), its beam from
    `position_m` along `direction` (both in base_link), Gaussian noise of `noise_std_m` on each
    reading in range.

    A file without the table (or a key) takes these: the quad's (and the hexacopter's), a PX4
    downward rangefinder of the Benewake TFmini Plus kind (its datasheet: 0.1-12 m indoors, a
    3.6 deg field of view, +-5 cm to 6 m; PX4 reads it at up to 100 Hz) at 60 Hz, a divisor of
    the physics rate, inside the body's box 5 mm above its bottom (a ray leaves its own body's
    box unseen), pointing down."""

    rate_hz: int = 60
    min_range_m: float = 0.1
    max_range_m: float = 12.0
    field_of_view_rad: float = 0.063
    noise_std_m: float = 0.02
    radiation_type: RadiationType = RadiationType.INFRARED
    position_m: Vec3 = (0.0, 0.0, -0.045)
    direction: Vec3 = (0.0, 0.0, -1.0)


@dataclass(frozen=True)
class LidarParams:
    """The [lidar] table: a scanning LiDAR at `position_m` in base_link (its frame's axes are
    base_link's). A 2D scan is one ring of `samples` beams in the x-y plane; a 3D scan has
    `channels` rings spread evenly over [-vertical_fov_rad / 2, +vertical_fov_rad / 2] of
    elevation, `samples` beams each. Ranges in [min_range_m, max_range_m], Gaussian noise of
    `noise_std_m` on each return.

    A file without the table (or a key) takes these: the quad's (and the hexacopter's), a
    16-channel spinning LiDAR of the Velodyne VLP-16 kind (its datasheet: 100 m, +-15 deg
    vertically, 3 cm accuracy, 5-20 Hz) at 10 Hz, in 1 deg steps across (a VLP-16's are 0.2 deg
    at 10 Hz: five times the rays and the cost), 30 m of range (the worlds are rooms), on top of
    the body above the rotors' discs."""

    rate_hz: int = 10
    samples: int = 360
    channels: int = 16
    vertical_fov_rad: float = 0.5236  # 30 deg
    min_range_m: float = 0.1
    max_range_m: float = 30.0
    noise_std_m: float = 0.015
    position_m: Vec3 = (0.0, 0.0, 0.06)


#: the most rays one scan may cast: PyBullet's rayTestBatch takes at most 16,384 at a time
MAX_LIDAR_RAYS = 16_384


@dataclass(frozen=True)
class VehicleParams:
    """Everything physical about the vehicle, in SI units. Built by `load_vehicle`."""

    name: str
    urdf_path: Path
    params_path: Path
    mass_kg: float
    inertia_kgm2: Mat3  # about the centre of mass, in base_link axes
    com_m: Vec3  # centre of mass relative to the base_link origin
    rotors: tuple[RotorSpec, ...]  # rotor_1..rotor_N, in number order
    thrust_coefficient_n_per_rad2s2: float
    torque_coefficient_nm_per_rad2s2: float
    max_thrust_n: float
    motor_time_constant_s: float
    aero: AeroParams
    imu_noise: ImuNoiseParams
    limits: CommandLimits
    camera_mounts: tuple[CameraMount, ...]
    contact: ContactParams = ContactParams(0.0, 0.5)
    gravity_mps2: float = 9.81
    #: every link but base_link, in the URDF's order
    link_frames: tuple[LinkFrame, ...] = ()
    #: the range finder and the LiDAR it carries when a run turns them on ([range], [lidar])
    range_finder: RangeParams = RangeParams()
    lidar: LidarParams = LidarParams()
    #: the URDF PyBullet loads, when it is not urdf_path: a copy naming binary STL versions of its
    #: ASCII STL meshes (vehicle/meshes.py)
    pybullet_copy: Path | None = field(default=None, compare=False)

    @property
    def pybullet_urdf_path(self) -> Path:
        """The URDF to give PyBullet: urdf_path, or the copy PyBullet can read all of."""
        return self.pybullet_copy or self.urdf_path

    @property
    def camera_links(self) -> tuple[str, ...]:
        return tuple(m.link_name for m in self.camera_mounts)

    def camera_mount(self, link_name: str) -> CameraMount:
        for mount in self.camera_mounts:
            if mount.link_name == link_name:
                return mount
        raise ConfigError(f"{self.urdf_path.name}: no camera link named {link_name!r} (have {list(self.camera_links)})")

    @property
    def yaw_torque_per_thrust_m(self) -> float:
        """Reaction torque per newton of thrust (k_m / k_f), m."""
        return self.torque_coefficient_nm_per_rad2s2 / self.thrust_coefficient_n_per_rad2s2

    @property
    def rotor_count(self) -> int:
        return len(self.rotors)

    @property
    def rotor_hubs_m(self) -> tuple[Vec3, ...]:
        """Each rotor's hub from base_link's origin, in base_link (a RotorSpec's position is
        from the centre of mass)."""
        cx, cy, cz = self.com_m
        return tuple((cx + x, cy + y, cz + z) for x, y, z in (r.position_m for r in self.rotors))

    @property
    def weight_n(self) -> float:
        return self.mass_kg * self.gravity_mps2

    @property
    def hover_thrust_per_rotor_n(self) -> float:
        return self.weight_n / len(self.rotors)

    def to_dict(self) -> dict[str, Any]:
        """Plain data for recording metadata."""
        return {
            "name": self.name,
            "urdf": str(self.urdf_path),
            "params": str(self.params_path),
            "mass_kg": self.mass_kg,
            "inertia_kgm2": [list(r) for r in self.inertia_kgm2],
            "com_m": list(self.com_m),
            "rotors": [
                {"link": r.link_name, "position_m": list(r.position_m), "spin": r.spin.value} for r in self.rotors
            ],
            "thrust_coefficient_n_per_rad2s2": self.thrust_coefficient_n_per_rad2s2,
            "torque_coefficient_nm_per_rad2s2": self.torque_coefficient_nm_per_rad2s2,
            "max_thrust_n": self.max_thrust_n,
            "motor_time_constant_s": self.motor_time_constant_s,
            "aero": _plain(self.aero),
            "imu_noise": _plain(self.imu_noise),
            "limits": _plain(self.limits),
            "contact": _plain(self.contact),
        }


def _plain(section: object) -> dict[str, Any]:
    """A section's fields as plain data (its vectors as lists), for recording metadata."""
    return {key: list(value) if isinstance(value, tuple) else value for key, value in vars(section).items()}


def default_params_path(urdf_path: Path) -> Path:
    """The parameter file lives beside the URDF: NAME.urdf -> NAME.params.toml."""
    return urdf_path.with_suffix(".params.toml")


def load_vehicle(urdf_path: Path | str | None = None, params_path: Path | str | None = None) -> VehicleParams:
    """Read and validate a vehicle. Raises ConfigError naming the file and field at fault."""
    urdf = Path(urdf_path) if urdf_path is not None else DEFAULT_URDF
    params = Path(params_path) if params_path is not None else default_params_path(urdf)
    if not urdf.is_file():
        raise ConfigError(f"vehicle URDF {'is a folder' if urdf.is_dir() else 'not found'}: {urdf}")
    if not params.is_file():
        raise ConfigError(f"vehicle parameter file not found: {params} (expected beside {urdf.name})")
    links = _read_urdf(urdf)
    table = read_toml(params, "vehicle parameter file")
    _refuse_unknown_keys(table, params)
    return _build(urdf, params, links, table)


# --- URDF -----------------------------------------------------------------------------------


@dataclass(frozen=True)
class _Link:
    name: str
    mass_kg: float
    com_in_link_m: Vec3
    inertia_in_link: Mat3  # about the link's CoM, in link axes (inertial rpy applied)
    origin_in_base_m: Vec3  # link frame origin in base_link
    rotation_in_base: Mat3  # base_link <- link


def _floats(text: str | None, count: int, where: str) -> tuple[float, ...]:
    try:
        values = tuple(float(v) for v in (text or "").split())
    except ValueError:
        raise ConfigError(f"{where}: expected {_numbers(count)}, got {text!r}") from None
    if len(values) != count or not all(math.isfinite(v) for v in values):
        raise ConfigError(f"{where}: expected {_numbers(count, 'finite ')}, got {text!r}")
    return values


def _numbers(count: int, kind: str = "") -> str:
    return f"{count} {kind}number{'s' * (count != 1)}"


def _origin(elem: ET.Element | None, where: str) -> tuple[Vec3, Mat3]:
    if elem is None:
        return (0.0, 0.0, 0.0), IDENTITY
    xyz = _floats(elem.get("xyz", "0 0 0"), 3, f"{where} origin xyz")
    rpy = _floats(elem.get("rpy", "0 0 0"), 3, f"{where} origin rpy")
    return xyz, matrix_from_rpy(*rpy)  # type: ignore[return-value]


def _inertials(root: ET.Element, path: Path) -> dict[str, tuple[float, Vec3, Mat3]]:
    """Each link's mass, centre of mass and inertia in its own frame (zero without <inertial>)."""
    raw: dict[str, tuple[float, Vec3, Mat3]] = {}
    for link in root.findall("link"):
        name = link.get("name", "")
        inertial = link.find("inertial")
        if inertial is None:
            raw[name] = (0.0, (0.0, 0.0, 0.0), ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)))
            continue
        where = f"{path.name}: link {name!r} inertial"
        mass_elem = inertial.find("mass")
        if mass_elem is None:
            raise ConfigError(f"{where}: missing <mass>")
        (mass,) = _floats(mass_elem.get("value"), 1, f"{where} mass")
        if mass <= 0.0:
            raise ConfigError(f"{where}: mass must be > 0 kg, got {mass}")
        com, rot = _origin(inertial.find("origin"), where)
        ie = inertial.find("inertia")
        if ie is None:
            raise ConfigError(f"{where}: missing <inertia>")
        vals = {}
        for key in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz"):
            (vals[key],) = _floats(ie.get(key), 1, f"{where} inertia {key}")
        inertia = (
            (vals["ixx"], vals["ixy"], vals["ixz"]),
            (vals["ixy"], vals["iyy"], vals["iyz"]),
            (vals["ixz"], vals["iyz"], vals["izz"]),
        )
        if min(vals["ixx"], vals["iyy"], vals["izz"]) <= 0.0:
            raise ConfigError(f"{where}: principal inertia must be > 0 kg m^2")
        raw[name] = (mass, com, mat_mul(mat_mul(rot, inertia), transpose(rot)))

    return raw


def _fixed_joints(root: ET.Element, path: Path) -> dict[str, tuple[str, Vec3, Mat3]]:
    """child link -> (parent link, origin, rotation) of every joint, all of them fixed."""
    parent_of: dict[str, tuple[str, Vec3, Mat3]] = {}
    for joint in root.findall("joint"):
        jname = joint.get("name", "")
        if joint.get("type") != "fixed":
            raise ConfigError(
                f"{path.name}: joint {jname!r} is {joint.get('type')!r}; a multirotor body uses fixed joints only"
            )
        parent = joint.find("parent")
        child = joint.find("child")
        if parent is None or child is None:
            raise ConfigError(f"{path.name}: joint {jname!r} needs <parent> and <child>")
        xyz, rot = _origin(joint.find("origin"), f"{path.name}: joint {jname!r}")
        parent_of[child.get("link", "")] = (parent.get("link", ""), xyz, rot)
    return parent_of


def _read_urdf(path: Path) -> dict[str, _Link]:
    """Every link of a URDF, its inertial block checked, placed in base_link through the fixed joints."""
    try:
        root = ET.parse(path).getroot()
    except ET.ParseError as exc:
        raise ConfigError(f"{path}: not valid XML ({exc})") from None
    if root.tag != "robot":
        raise ConfigError(f"{path}: root element is <{root.tag}>, expected <robot>")
    for mesh in root.iter("mesh"):
        name = mesh.get("filename", "")
        if "://" in name:
            raise ConfigError(f"{path.name}: mesh {name!r}: URLs are not supported; give a path relative to the URDF")
        if not name or not (path.parent / name).is_file():
            raise ConfigError(f"{path.name}: mesh file not found: {name!r} (looked in {path.parent})")
    raw = _inertials(root, path)

    parent_of = _fixed_joints(root, path)  # place every link in base_link through the fixed-joint tree
    roots = [n for n in raw if n not in parent_of]
    if roots != ["base_link"]:
        raise ConfigError(f"{path.name}: expected one root link named 'base_link', found {roots}")

    links: dict[str, _Link] = {}
    for name, (mass, com, inertia) in raw.items():
        origin_in_base: Vec3 = (0.0, 0.0, 0.0)
        rotation_in_base: Mat3 = IDENTITY
        node = name
        while node in parent_of:  # compose child -> ... -> base_link
            parent_name, xyz, joint_rotation = parent_of[node]
            rotated = rotate(joint_rotation, origin_in_base)
            origin_in_base = (rotated[0] + xyz[0], rotated[1] + xyz[1], rotated[2] + xyz[2])
            rotation_in_base = mat_mul(joint_rotation, rotation_in_base)
            node = parent_name
        links[name] = _Link(name, mass, com, inertia, origin_in_base, rotation_in_base)
    return links


def _composite_inertia(links: dict[str, _Link]) -> tuple[float, Vec3, Mat3]:
    """Total mass, centre of mass and inertia about it (parallel-axis theorem), in base_link."""
    total = sum(link.mass_kg for link in links.values())
    centres = {}
    for name, link in links.items():
        c = rotate(link.rotation_in_base, link.com_in_link_m)
        centres[name] = (
            c[0] + link.origin_in_base_m[0],
            c[1] + link.origin_in_base_m[1],
            c[2] + link.origin_in_base_m[2],
        )
    com = tuple(sum(links[n].mass_kg * centres[n][i] for n in links) / total for i in range(3))
    inertia = [[0.0] * 3 for _ in range(3)]
    for name, link in links.items():
        rot = link.rotation_in_base
        local = mat_mul(mat_mul(rot, link.inertia_in_link), transpose(rot))
        d = tuple(centres[name][i] - com[i] for i in range(3))
        d2 = d[0] ** 2 + d[1] ** 2 + d[2] ** 2
        for i in range(3):
            for j in range(3):
                inertia[i][j] += local[i][j] + link.mass_kg * ((d2 if i == j else 0.0) - d[i] * d[j])
    return total, com, tuple(tuple(r) for r in inertia)  # type: ignore[return-value]


# --- parameter file -------------------------------------------------------------------------


#: Each number's sensible range in a vehicle parameter file, by table and key, in the order they
#: are read: (low, high), or (low, high, default) for a key a file may leave out (one added after
#: recordings were made: their attached parameter files still load). A key of [range] or [lidar]
#: a file leaves out (or the whole table) takes RangeParams' or LidarParams' default.
_BOUNDS: dict[str, dict[str, tuple[float, ...]]] = {
    "rotors": {
        "thrust_coefficient_n_per_rad2s2": (1e-9, 1.0),
        "torque_coefficient_nm_per_rad2s2": (1e-12, 1.0),
        "max_thrust_n": (1e-3, 1e4),
        "motor_time_constant_s": (0.0, 1.0),
    },
    "aero": {
        "body_drag_linear_ns_per_m": (0.0, 100.0),
        "body_drag_quadratic_ns2_per_m2": (0.0, 100.0),
        "rotor_drag_ns_per_m_rad": (0.0, 1.0),
        # not modelled before it was a key: a file without it flies as it did
        "rotor_axial_drag_ns_per_m_rad": (0.0, 1.0, 0.0),
        "rotor_radius_m": (1e-3, 10.0),
        "ground_effect_max_ratio": (1.0, 3.0),
    },
    "imu": {
        "gyro_noise_density_radps_per_rthz": (0.0, 1.0),
        "gyro_bias_random_walk_radps2_per_rthz": (0.0, 1.0),
        "accel_noise_density_mps2_per_rthz": (0.0, 10.0),
        "accel_bias_random_walk_mps3_per_rthz": (0.0, 10.0),
    },
    "limits": {
        "max_horizontal_speed_mps": (0.1, 50.0),
        "max_climb_rate_mps": (0.1, 20.0),
        "max_descent_rate_mps": (0.1, 20.0),
        "max_yaw_rate_radps": (0.1, 20.0),
        "min_altitude_m": (0.0, 10.0),
        "max_altitude_m": (0.5, 10000.0),
    },
    # a file without the table (one older than it) keeps PyBullet's own figures, as it flew before
    "contact": {"restitution": (0.0, 1.0, 0.0), "lateral_friction": (0.0, 10.0, 0.5)},
    "range": {
        "min_range_m": (0.0, 1000.0),
        "max_range_m": (0.0, 1000.0),
        "direction": (-1.0, 1.0),
        "rate_hz": (1, 10_000),
        "field_of_view_rad": (0.0, math.pi),
        "noise_std_m": (0.0, 10.0),
        "position_m": (-10.0, 10.0),
    },
    "lidar": {
        "samples": (1, MAX_LIDAR_RAYS),
        "channels": (1, 128),
        "min_range_m": (0.0, 1000.0),
        "max_range_m": (0.0, 1000.0),
        "rate_hz": (1, 1000),
        "vertical_fov_rad": (0.0, math.pi),
        "noise_std_m": (0.0, 10.0),
        "position_m": (-10.0, 10.0),
    },
}

#: The tables of a vehicle parameter file and the keys of each ([rotors] spin holds one entry
#: per rotor link, checked against the URDF).
PARAM_KEYS: dict[str, tuple[str, ...]] = {
    "rotors": ("spin", *_BOUNDS["rotors"]),
    "aero": tuple(f.name for f in fields(AeroParams)),
    "imu": tuple(f.name for f in fields(ImuNoiseParams)),
    "limits": tuple(f.name for f in fields(CommandLimits)),
    "contact": tuple(f.name for f in fields(ContactParams)),
    "range": tuple(f.name for f in fields(RangeParams)),
    "lidar": tuple(f.name for f in fields(LidarParams)),
}


def _refuse_unknown_keys(table: dict[str, Any], path: Path) -> None:
    """ConfigError naming the file, the table and the first key the parameter file has no use for."""
    refuse_unknown_keys(
        table,
        tuple(PARAM_KEYS),
        str(path),
        top_level=True,
        otherwise=f"a vehicle parameter file has the tables {', '.join(f'[{t}]' for t in PARAM_KEYS)}",
    )
    for section, keys in PARAM_KEYS.items():
        value = table.get(section)
        if isinstance(value, dict):
            refuse_unknown_keys(value, keys, f"{path}: [{section}]")


def _number(
    table: dict[str, Any],
    section: str,
    key: str,
    path: Path,
    *,
    low: float,
    high: float,
    default: float | None = None,
) -> float:
    """[section] key, a finite number in [low, high]; `default` when the file leaves it out (a key
    added after recordings were made: their attached parameter files still load), else refused."""
    sec = table.get(section)
    if sec is not None and not isinstance(sec, dict):
        raise ConfigError(f"{path}: [{section}] must be a table, got {sec!r}")
    if sec is None or key not in sec:
        if default is not None:
            return default
        raise ConfigError(f"{path}: missing [{section}] {key}")
    value = sec[key]
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise ConfigError(f"{path}: [{section}] {key} must be a number, got {value!r}")
    if not low <= value <= high:
        raise ConfigError(f"{path}: [{section}] {key} = {value} is outside the sensible range [{low}, {high}]")
    return float(value)


def _vector(table: dict[str, Any], section: str, key: str, path: Path, *, low: float, high: float) -> Vec3:
    value = table.get(section, {}).get(key) if isinstance(table.get(section), dict) else None
    if (
        not isinstance(value, list)
        or len(value) != 3
        or not all(isinstance(v, (int, float)) and not isinstance(v, bool) and low <= v <= high for v in value)
    ):
        raise ConfigError(f"{path}: [{section}] {key} must be 3 numbers in [{low}, {high}], got {value!r}")
    return (float(value[0]), float(value[1]), float(value[2]))


def _aero(table: dict[str, Any], path: Path) -> AeroParams:
    ground_effect = table.get("aero", {}).get("ground_effect") if isinstance(table.get("aero"), dict) else None
    if not isinstance(ground_effect, bool):
        raise ConfigError(f"{path}: [aero] ground_effect must be true or false, got {ground_effect!r}")
    return AeroParams(ground_effect=ground_effect, **_section(AeroParams, table, "aero", path))


def _section(kind: type, table: dict[str, Any], section: str, path: Path) -> dict[str, Any]:
    """The keys of [section] that _BOUNDS holds, each read as the field of `kind` it fills is
    typed (3 numbers, a whole number or a number) within its bounds; one the file leaves out takes
    its default there, else its field's, else is refused."""
    own = {f.name: (f.type, f.default) for f in fields(kind)}
    sec = table.get(section)
    values: dict[str, Any] = {}
    for key, (low, high, *default) in _BOUNDS[section].items():
        typed, field_default = own[key]
        fallback: Any = default[0] if default else None if field_default is MISSING else field_default
        if typed == "Vec3":
            absent = fallback is not None and (not isinstance(sec, dict) or key not in sec)
            values[key] = fallback if absent else _vector(table, section, key, path, low=low, high=high)
        elif typed == "int":
            values[key] = _whole(table, section, key, path, low=low, high=high, default=fallback)
        else:
            values[key] = _number(table, section, key, path, low=low, high=high, default=fallback)
    return values


#: The fewest rotors that can give thrust and three independent torques.
MIN_ROTORS = 4


def _rotor_links(urdf: Path, links: dict[str, _Link]) -> list[str]:
    """The rotor links, rotor_1..rotor_N in number order (N >= 4, none missing)."""
    numbered = []
    for name in links:
        match = re.fullmatch(r"rotor_(\d+)", name)
        if match:
            numbered.append((int(match.group(1)), name))
        elif name.startswith("rotor_"):
            raise ConfigError(f"{urdf.name}: link {name!r} looks like a rotor but is not named rotor_<number>")
    names = [name for _, name in sorted(numbered)]
    expected = [f"rotor_{i}" for i in range(1, len(names) + 1)]
    if len(names) < MIN_ROTORS or names != expected:
        raise ConfigError(
            f"{urdf.name}: expected rotor links named rotor_1..rotor_N with N >= {MIN_ROTORS}, found {names}"
        )
    return names


def _rotors(
    urdf: Path, params: Path, links: dict[str, _Link], rotor_names: list[str], spins: dict[str, Any], com: Vec3
) -> list[RotorSpec]:
    """Each rotor link's spin, level axis and position from the centre of mass; as many ccw as cw."""
    rotors = []
    for name in rotor_names:
        spin_text = spins.get(name)
        try:
            spin = Spin(str(spin_text).lower())
        except ValueError:
            raise ConfigError(f'{params}: [rotors] spin.{name} must be "ccw" or "cw", got {spin_text!r}') from None
        axis = rotate(links[name].rotation_in_base, (0.0, 0.0, 1.0))
        if axis[2] < 0.999:
            raise ConfigError(f"{urdf.name}: link {name!r} must be level (its z axis along base_link z)")
        o = links[name].origin_in_base_m
        rotors.append(RotorSpec(name, (o[0] - com[0], o[1] - com[1], o[2] - com[2]), spin))
    ccw = sum(r.spin is Spin.CCW for r in rotors)
    if 2 * ccw != len(rotors):
        # equal thrusts must give no net yaw torque, or hovering would need a yaw trim
        raise ConfigError(
            f"{params}: [rotors] spin must have as many ccw as cw rotors; {ccw} of the {len(rotors)} rotors are ccw"
        )

    return rotors


def _whole(table: dict[str, Any], section: str, key: str, path: Path, *, low: float, high: float, default: int) -> int:
    """[section] key, a whole number in [low, high], `default` when the file leaves it out."""
    sec = table.get(section)
    value = sec.get(key, default) if isinstance(sec, dict) else default
    if isinstance(value, bool) or not isinstance(value, int) or not low <= value <= high:
        raise ConfigError(f"{path}: [{section}] {key} must be a whole number in [{low}, {high}], got {value!r}")
    return value


def _range(table: dict[str, Any], path: Path) -> RangeParams:
    """The [range] table; what the file leaves out (or a file without the table) takes RangeParams' defaults."""
    values = _section(RangeParams, table, "range", path)
    _span(values, "range", path)
    sec, default = table.get("range", {}), RangeParams.radiation_type.value
    kind = sec.get("radiation_type", default) if isinstance(sec, dict) else default
    if not isinstance(kind, str) or kind not in {r.value for r in RadiationType}:
        raise ConfigError(f'{path}: [range] radiation_type must be "infrared" or "ultrasound", got {kind!r:.40}')
    direction = values["direction"]
    norm = math.sqrt(sum(c * c for c in direction))
    if norm < 1e-6:
        raise ConfigError(f"{path}: [range] direction must not be zero")
    values["direction"] = (direction[0] / norm, direction[1] / norm, direction[2] / norm)
    return RangeParams(radiation_type=RadiationType(kind), **values)


def _lidar(table: dict[str, Any], path: Path) -> LidarParams:
    """The [lidar] table; what the file leaves out (or a file without the table) takes LidarParams' defaults."""
    values = _section(LidarParams, table, "lidar", path)
    rays = values["samples"] * values["channels"]
    if rays > MAX_LIDAR_RAYS:
        raise ConfigError(f"{path}: [lidar] samples x channels = {rays} is over {MAX_LIDAR_RAYS} rays")
    _span(values, "lidar", path)
    return LidarParams(**values)


def _span(values: dict[str, Any], section: str, path: Path) -> None:
    """[section] min_range_m must be below max_range_m."""
    if not values["min_range_m"] < values["max_range_m"]:
        raise ConfigError(f"{path}: [{section}] min_range_m must be below max_range_m")


def _build(urdf: Path, params: Path, links: dict[str, _Link], table: dict[str, Any]) -> VehicleParams:
    """The vehicle from its URDF's links and its parameter file, every field checked."""
    mass, com, inertia = _composite_inertia(links)
    rotor_names = _rotor_links(urdf, links)
    section = table.get("rotors", {})
    if not isinstance(section, dict):
        raise ConfigError(f"{params}: [rotors] must be a table, got {section!r:.40}")
    spins = section.get("spin")
    if not isinstance(spins, dict):
        raise ConfigError(f'{params}: missing [rotors] spin = {{ rotor_1 = "ccw", ... }}')
    unknown = sorted(set(spins) - set(rotor_names))
    if unknown:
        raise ConfigError(f"{params}: [rotors] spin names {unknown}, which {urdf.name} has no link for")
    rotors = _rotors(urdf, params, links, rotor_names, spins, com)

    coefficients = _section(VehicleParams, table, "rotors", params)  # thrust, torque, max_thrust_n, tau
    max_thrust = coefficients["max_thrust_n"]
    weight = mass * 9.81
    if len(rotors) * max_thrust < 1.2 * weight:
        raise ConfigError(
            f"{params}: [rotors] max_thrust_n = {max_thrust} gives {len(rotors) * max_thrust:.2f} N in all, "
            f"too little to fly a {weight:.2f} N vehicle (need at least 1.2x its weight)"
        )
    aero = _aero(table, params)
    imu = ImuNoiseParams(**_section(ImuNoiseParams, table, "imu", params))
    limits = CommandLimits(**_section(CommandLimits, table, "limits", params))
    if limits.min_altitude_m >= limits.max_altitude_m:
        raise ConfigError(f"{params}: [limits] min_altitude_m must be below max_altitude_m")
    if any(abs(v) > 1e-9 for v in links["base_link"].com_in_link_m):
        # PyBullet reports the base's pose at its inertial origin; keep that the link origin
        raise ConfigError(f"{urdf.name}: base_link's <inertial> origin must be at the link origin (0 0 0)")
    cameras = tuple(
        CameraMount(n, links[n].origin_in_base_m, links[n].rotation_in_base)
        for n in sorted(n for n in links if n.endswith("_camera_link"))
    )
    return VehicleParams(
        name=urdf.stem,
        urdf_path=urdf,
        params_path=params,
        mass_kg=mass,
        inertia_kgm2=inertia,
        com_m=com,
        rotors=tuple(rotors),
        **coefficients,
        aero=aero,
        imu_noise=imu,
        limits=limits,
        camera_mounts=cameras,
        contact=ContactParams(**_section(ContactParams, table, "contact", params)),
        range_finder=_range(table, params),
        lidar=_lidar(table, params),
        link_frames=tuple(
            LinkFrame(n, link.origin_in_base_m, link.rotation_in_base) for n, link in links.items() if n != "base_link"
        ),
        pybullet_copy=None if (readable := pybullet_urdf(urdf)) == urdf else readable,
    )
