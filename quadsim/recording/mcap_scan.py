"""Reading an MCAP file defensively: every length is checked against the file, every chunk's CRC
is verified, and damage is noted and stepped over instead of raised.

What a file holds is taken from its data section, chunk by chunk (as the MCAP CLI's `recover`
and `doctor` do). The summary section, when its CRC holds, only helps: it reaches chunks,
metadata and attachments that a damaged length field hides, and names the channels of a chunk
whose own channel records were lost. After a record whose length is absurd, reading resumes at
the next record that parses exactly (a chunk, metadata or attachment). Nothing is ever allocated
from a length field: reads are bounded by the file, and a chunk may not decompress to more than
a plausible multiple of its compressed size.

Used by the reader (`info`, `replay`, `replay --resim`, `check`) and by `recover`.
"""

from __future__ import annotations

import heapq
import mmap
import re
import struct
import zlib
from collections.abc import Iterator
from dataclasses import dataclass, field, replace
from pathlib import Path

from mcap.opcode import Opcode

from quadsim.core.invocation import program
from quadsim.errors import QuadsimError

MAGIC = b"\x89MCAP0\r\n"
HEADER, FOOTER, SCHEMA, CHANNEL, MESSAGE, CHUNK, MESSAGE_INDEX, CHUNK_INDEX = 1, 2, 3, 4, 5, 6, 7, 8
ATTACHMENT, ATTACHMENT_INDEX, STATISTICS, METADATA, METADATA_INDEX, SUMMARY_OFFSET, DATA_END = range(9, 16)
#: opcode -> the record's name as damage reports say it ("message index"): the MCAP spec's
RECORD_NAMES = {int(op): op.name.lower().replace("_", " ") for op in Opcode}
_SUMMARY_ONLY = {FOOTER, CHUNK_INDEX, ATTACHMENT_INDEX, STATISTICS, METADATA_INDEX, SUMMARY_OFFSET}
_LOOSE = {SCHEMA, CHANNEL, MESSAGE}  # records an unchunked file keeps in its data section
_RESYNC = re.compile(rb"[\x06\x09\x0c]")  # where reading may resume: chunk, attachment, metadata
_OP_LEN = struct.Struct("<BQ")
_MESSAGE_HEAD = struct.Struct("<HIQQ")
_FOOTER_SIZE = 9 + 20
_END = "the end of the file"
COMPRESSIONS = ("", "zstd", "lz4")
#: a chunk may decompress to at most this many times its compressed size, or this many bytes
MAX_RATIO = 1024
MIN_LIMIT_BYTES = 64 << 20


class _Bad(Exception):
    """A record (or part of one) that does not parse; the message says why."""


class _Fields:
    """Reads the fields of one record from buf[pos:end], never past end."""

    __slots__ = ("buf", "end", "pos")

    def __init__(self, buf: bytes | mmap.mmap, pos: int, end: int) -> None:
        self.buf, self.pos, self.end = buf, pos, end

    def take(self, n: int) -> bytes:
        if self.pos + n > self.end:
            raise _Bad("a field runs past the end of its record")
        out = self.buf[self.pos : self.pos + n]
        self.pos += n
        return bytes(out)

    def u16(self) -> int:
        return int.from_bytes(self.take(2), "little")

    def u32(self) -> int:
        return int.from_bytes(self.take(4), "little")

    def u64(self) -> int:
        return int.from_bytes(self.take(8), "little")

    def text(self) -> str:
        raw = self.take(self.u32())
        try:
            return raw.decode("utf-8")
        except UnicodeDecodeError:
            raise _Bad("a name or text that is not UTF-8") from None

    def text_map(self) -> dict[str, str]:
        size = self.u32()
        end = self.pos + size
        if end > self.end:
            raise _Bad("a map runs past the end of its record")
        out = {}
        while self.pos < end:
            key = self.text()
            out[key] = self.text()
        if self.pos != end:
            raise _Bad("a map entry runs past the end of the map")
        return out

    def exact(self) -> None:
        if self.pos != self.end:
            raise _Bad("the record's fields do not fill its length")


# --- what a file holds ---------------------------------------------------------------------------


@dataclass(frozen=True)
class SchemaDef:
    id: int
    name: str
    encoding: str
    data: bytes


@dataclass(frozen=True)
class ChannelDef:
    """One channel definition. Ids may be defined again (for another topic) later in a
    damaged or crafted file: each definition gets its own `key`, and a message belongs to the
    definition in force where it was read."""

    key: int
    id: int
    topic: str
    message_encoding: str
    metadata: dict[str, str]
    schema: SchemaDef | None


@dataclass(frozen=True)
class RawMessage:
    channel: ChannelDef
    sequence: int
    log_time: int
    publish_time: int
    data: bytes


@dataclass(frozen=True)
class MetadataRecord:
    name: str
    metadata: dict[str, str]
    offset: int
    repaired: bool = False  # its map length was wrong; its entries were read to the record's end


@dataclass(frozen=True)
class AttachmentRecord:
    name: str
    media_type: str
    log_time: int
    create_time: int
    offset: int
    data_at: int
    data_size: int
    repaired: bool = False  # its data size field was wrong; the size its CRC confirms was taken


@dataclass(frozen=True)
class Damage:
    """Something wrong with the file, where, and what it costs."""

    where: str
    why: str
    loses: str = "messages"  # messages, metadata, an attachment, nothing
    span_ns: tuple[int, int | None] | None = None  # messages lost between these log times (None: to the end)
    topics: tuple[str, ...] | None = None  # topics of the lost messages, when an index names them

    def describe(self) -> str:
        text = f"{self.where}: {self.why}"
        if self.loses == "nothing":
            return text + " (nothing is lost)"
        if self.loses != "messages":
            return text + f" ({self.loses} is lost)"
        on = f" on {', '.join(self.topics)}" if self.topics else ""
        if self.span_ns is None:
            return text if text.endswith("skipped") else text + f"; its messages{on} are skipped"
        start, end = self.span_ns
        if end is None:
            return text + f"; what was recorded after {start / 1e9:.2f} s is missing"
        return text + f"; its messages{on}, {start / 1e9:.2f} .. {end / 1e9:.2f} s, are skipped"


@dataclass
class _Segment:
    """A chunk, or a run of records an unchunked file keeps outside chunks."""

    offset: int
    end: int
    chunked: bool
    start_ns: int = 0
    end_ns: int = 0
    # ways to read its records, tried in turn: (compression, records at, records length,
    # uncompressed size, CRC); more than one when a length field disagrees with another
    readings: list[tuple[str, int, int, int, int]] = field(default_factory=list)
    channel_ids: set[int] = field(default_factory=set)  # from the message indexes after it
    # filled by the first reading pass
    ok: bool = False
    counts: dict[int, int] = field(default_factory=dict)  # channel key -> messages
    channels_at_start: dict[int, int] = field(default_factory=dict)  # channel id -> key
    schemas_at_start: dict[int, SchemaDef] = field(default_factory=dict)
    new_keys: list[int] = field(default_factory=list)  # keys of the channels it defines, in order
    reading: int = 0  # which of `readings` worked
    note: str = ""  # damage to its fields that cost nothing, if its records read
    header_span: tuple[int, int] | None = None  # the time range its own fields give
    first_message_ns: int | None = None  # the earliest log time of its readable messages (first pass)
    indexes: list[tuple[int, int, int]] = field(default_factory=list)  # message indexes: (channel id, at, bytes)


@dataclass
class _Summary:
    schemas: dict[int, SchemaDef] = field(default_factory=dict)
    channels: dict[int, tuple[int, str, str, dict[str, str]]] = field(default_factory=dict)
    chunk_indexes: list[tuple[int, int, int, int, set[int], str, int, int]] = field(default_factory=list)
    attachment_offsets: list[int] = field(default_factory=list)
    metadata_offsets: list[int] = field(default_factory=list)


def bag_file(path: Path) -> Path:
    """The MCAP file of `path`: the file itself, or the one .mcap file of a folder (`ros2 bag record
    -s mcap` writes a folder holding metadata.yaml and NAME_0.mcap). Every command that reads a
    recording takes either."""
    if not path.is_dir():
        return path
    files = sorted(p for p in path.glob("*.mcap") if p.is_file())
    if len(files) == 1:
        return files[0]
    if not files:
        raise QuadsimError(f"{path}: a folder with no .mcap file in it (a ros2 bag recorded with -s mcap has one)")
    names = ", ".join(p.name for p in files[:4]) + (", ..." if len(files) > 4 else "")
    raise QuadsimError(f"{path}: a folder of {len(files)} .mcap files ({names}): give the one you mean")


def check_is_mcap(path: Path, damaged_magic: bool = False) -> None:
    """Raise QuadsimError unless `path` is a readable file starting with the MCAP magic (or,
    with `damaged_magic`, at least 8 bytes long: the caller looks further)."""
    if not path.exists():
        raise QuadsimError(f"{path}: no such file")
    if not path.is_file():
        raise QuadsimError(f"{path}: not a file")
    try:
        with open(path, "rb") as fh:
            head = fh.read(len(MAGIC))
    except OSError as exc:
        raise QuadsimError(f"{path}: cannot read ({exc.strerror})") from None
    if not head:
        raise QuadsimError(f"{path}: empty file (0 bytes), not an MCAP recording")
    if damaged_magic and len(head) == len(MAGIC):
        return
    if head != MAGIC[: len(head)] or len(head) < len(MAGIC):
        raise QuadsimError(f"{path}: not an MCAP file (it does not start with the MCAP magic bytes)")


class McapFile:
    """An MCAP file read defensively. Opening it reads its structure and verifies every chunk
    (counting messages per channel); `messages` reads the messages again, chunk by chunk."""

    def __init__(self, path: Path | str) -> None:
        self.path = Path(path)
        check_is_mcap(self.path, damaged_magic=True)
        try:
            self._fh = open(self.path, "rb")
        except OSError as exc:
            raise QuadsimError(f"{self.path}: cannot read ({exc.strerror})") from None
        self._map: mmap.mmap | None = None
        try:
            self._map = mmap.mmap(self._fh.fileno(), 0, access=mmap.ACCESS_READ)
            self._buf: bytes | mmap.mmap = self._map
        except (OSError, ValueError):  # a file system without mmap: read it
            self._buf = self._fh.read()
        self.size = len(self._buf)
        self.profile = ""
        self.library = ""
        self.has_header = False
        self.damage: list[Damage] = []
        self.notes: list[str] = []  # oddities that cost no data (a channel id defined twice...)
        self.channels: list[ChannelDef] = []
        self.metadata: list[MetadataRecord] = []
        self.attachments: list[AttachmentRecord] = []
        self.counts: dict[int, int] = {}  # channel key -> messages
        self.first_ns: dict[int, int] = {}
        self.last_ns: dict[int, int] = {}
        self.orphans = 0  # messages on a channel id no readable record defines
        self.data_end_reached = False
        self.summary_ok = False
        self._segments: list[_Segment] = []
        self._summary = _Summary()
        self._summary_keys: dict[int, int] = {}  # channel id -> key of a definition from the summary
        self._walk_damage: list[tuple[int, int, int]] = []  # (index in damage, from byte, to byte)
        self._ends_with_magic = self._buf[-len(MAGIC) :] == MAGIC
        try:
            self._read()
        except BaseException:
            self.close()
            raise

    # --- public --------------------------------------------------------------------------------

    @property
    def message_count(self) -> int:
        return sum(self.counts.values())

    @property
    def chunk_count(self) -> int:
        """Chunks whose records were read (CRC verified)."""
        return sum(1 for s in self._segments if s.ok and s.chunked)

    @property
    def span_ns(self) -> tuple[int, int]:
        if not self.first_ns:
            return (0, 0)
        return min(self.first_ns.values()), max(self.last_ns.values())

    @property
    def complete(self) -> bool:
        """Finished properly and undamaged: every record readable, summary and footer in place."""
        return self.data_end_reached and self.summary_ok and not self.damage

    @property
    def loses_messages(self) -> bool:
        return any(d.loses == "messages" for d in self.damage) or self.orphans > 0

    def attachment_data(self, a: AttachmentRecord) -> bytes:
        return bytes(self._buf[a.data_at : a.data_at + a.data_size])

    def messages(self, keys: set[int] | None = None, log_time_order: bool = True) -> Iterator[RawMessage]:
        """Messages of the channels with these keys (all: None), from every readable chunk; in
        log-time order (file order among equal times), streamed: a chunk is read when the merge
        reaches its earliest message, so memory holds the chunks whose times overlap, not the file."""
        segments = [s for s in self._segments if s.ok and (keys is None or keys & s.counts.keys())]
        if not log_time_order:
            for seg in segments:
                yield from self._parse_segment(seg, self._records_of(seg, seg.readings[seg.reading]), keys, False)
            return
        segments.sort(key=lambda s: (s.first_message_ns or 0, s.offset))
        heap: list[tuple[int, int, int, RawMessage, Iterator[tuple[int, RawMessage]]]] = []
        opened = 0
        while heap or opened < len(segments):
            while opened < len(segments) and (not heap or (segments[opened].first_message_ns or 0) <= heap[0][0]):
                seg = segments[opened]
                opened += 1
                raw = self._records_of(seg, seg.readings[seg.reading])
                ordered = sorted(enumerate(self._parse_segment(seg, raw, keys, False)), key=lambda im: im[1].log_time)
                del raw
                pending = iter(ordered)
                first = next(pending, None)
                if first is not None:
                    heapq.heappush(heap, (first[1].log_time, seg.offset, first[0], first[1], pending))
            _, offset, _, message, pending = heapq.heappop(heap)
            yield message
            following = next(pending, None)
            if following is not None:
                heapq.heappush(heap, (following[1].log_time, offset, following[0], following[1], pending))

    def damage_report(self) -> str:
        """One paragraph: what is wrong, how much is readable, what to do."""
        t0, t1 = self.span_ns
        if not self.damage:
            return f"{self.path}: no damage found"
        first = self.damage[0].describe()
        more = f" (and {len(self.damage) - 1} more problems)" if len(self.damage) > 1 else ""
        lost = self.loses_messages
        cut = [d.where == _END for d in self.damage if d.loses == "messages"]
        kind = "cut short" if cut and all(cut) and not self.orphans else "damaged"
        readable = (
            f"Readable: {self.message_count} messages in {self.chunk_count} complete chunks, {t0 / 1e9:.2f} .. "
            f"{t1 / 1e9:.2f} s."
        )
        if not self.message_count:
            action = " Nothing can be recovered."
        elif lost:
            action = f" Run '{program()} recover {self.path}' to save them to an indexed file."
        else:
            action = f" Nothing is lost: '{program()} recover {self.path}' rewrites it as a sound file."
        said = "" if kind == "cut short" else f"{kind}: "  # its first problem says 'cut short' itself
        return f"{self.path}: {said}{first}{more}. {readable}{action}"

    def close(self) -> None:
        self._buf = b""
        if self._map is not None:
            self._map.close()
            self._map = None
        self._fh.close()

    def __enter__(self) -> McapFile:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # --- reading the structure -----------------------------------------------------------------

    def _read(self) -> None:
        if self._buf[: len(MAGIC)] != MAGIC:
            # damaged magic bytes: still an MCAP file if a header follows them or it ends with the magic
            head_ok = (
                self.size >= 17 and self._buf[8] == HEADER and 17 + _OP_LEN.unpack_from(self._buf, 8)[1] <= self.size
            )
            if not head_ok and self._buf[-len(MAGIC) :] != MAGIC:
                raise QuadsimError(f"{self.path}: not an MCAP file (it does not start with the MCAP magic bytes)")
            self._damage("the start of the file", "the MCAP magic bytes are damaged", "nothing")
        limit = self._read_footer_and_summary()
        self._walk(limit)
        explained = any(d.where in ("the footer", "the summary section") for d in self.damage)
        if self.data_end_reached and not self.summary_ok and not explained:
            self._damage(_END, "no readable footer after the data section", "nothing")
        self._add_indexed()
        for seg in self._segments:
            if not seg.chunked:
                seg.readings = [("", seg.offset, seg.end - seg.offset, seg.end - seg.offset, 0)]
        self._segments.sort(key=lambda s: s.offset)
        if not self.has_header and not self._segments and not self.metadata and not self.attachments:
            raise QuadsimError(f"{self.path}: MCAP magic but no readable header; nothing can be recovered")
        self._first_pass()
        self._resolve_walk_damage()
        last = self.span_ns[1]
        self.damage = [
            replace(d, span_ns=(last, None)) if d.where == _END and d.loses == "messages" else d for d in self.damage
        ]

    def _damage(self, where: str, why: str, loses: str = "messages", **kw: object) -> None:
        self.damage.append(Damage(where, why, loses, **kw))  # type: ignore[arg-type]

    def _read_footer_and_summary(self) -> int:
        """Check the footer and read the summary if its CRC holds; returns where the data
        section ends at the latest (the summary's start, else the end of the file)."""
        buf, size = self._buf, self.size
        if size < len(MAGIC) + _FOOTER_SIZE + len(MAGIC) or buf[size - len(MAGIC) :] != MAGIC:
            return size  # cut short, or something else at the end: the walk will say what
        at = size - len(MAGIC) - _FOOTER_SIZE
        op, length = _OP_LEN.unpack_from(buf, at)
        if op != FOOTER or length != 20:
            self._damage("the footer", "unreadable", "nothing")
            return size
        summary_start, _summary_offset_start, crc = struct.unpack_from("<QQI", buf, at + 9)
        if summary_start == 0:
            self.summary_ok = True  # a file without a summary is complete without one
            return at
        if not len(MAGIC) < summary_start <= at:
            self._damage("the footer", f"it points the summary at byte {summary_start}, outside the file", "nothing")
            return size
        if crc != 0 and zlib.crc32(buf[summary_start : at + 9 + 16]) != crc:
            self._damage("the summary section", "its CRC does not match; read without it", "nothing")
            return size
        try:
            self._parse_summary(summary_start, at)
        except _Bad as exc:
            self._summary = _Summary()
            self._damage("the summary section", f"unreadable ({exc}); read without it", "nothing")
            return size
        self.summary_ok = True
        return summary_start

    def _parse_summary(self, start: int, end: int) -> None:
        s, buf, pos = self._summary, self._buf, start
        while pos < end:
            if pos + 9 > end:
                raise _Bad("a record is cut off")
            op, length = _OP_LEN.unpack_from(buf, pos)
            body, rec_end = pos + 9, pos + 9 + length
            if rec_end > end:
                raise _Bad(f"a {RECORD_NAMES.get(op, 'unknown')} record runs past the footer")
            f = _Fields(buf, body, rec_end)
            if op == SCHEMA:
                sid, name, enc, data = f.u16(), f.text(), f.text(), f.take(f.u32())
                s.schemas[sid] = SchemaDef(sid, name, enc, data)
            elif op == CHANNEL:
                cid, sid, topic, enc, md = f.u16(), f.u16(), f.text(), f.text(), f.text_map()
                s.channels[cid] = (sid, topic, enc, md)
            elif op == CHUNK_INDEX:
                t0, t1, offset, chunk_len = f.u64(), f.u64(), f.u64(), f.u64()
                ids_size = f.u32()
                ids_end = f.pos + ids_size
                ids = set()
                while f.pos < ids_end:
                    ids.add(f.u16())
                    f.u64()
                _mi_len, compression, compressed, uncompressed = f.u64(), f.text(), f.u64(), f.u64()
                s.chunk_indexes.append((t0, t1, offset, chunk_len, ids, compression, compressed, uncompressed))
            elif op == ATTACHMENT_INDEX:
                s.attachment_offsets.append(f.u64())
            elif op == METADATA_INDEX:
                s.metadata_offsets.append(f.u64())
            pos = rec_end

    def _walk(self, limit: int) -> None:
        """Read the data section record by record, from the header to `limit`.

        It is one piece: a loop over hostile bytes whose every branch checks a record's bounds
        against the same position and the same open chunk, and reads best where each check sits
        beside the read it guards."""
        buf = self._buf
        pos = len(MAGIC)
        loose: _Segment | None = None
        last_chunk: _Segment | None = None
        while True:
            if pos >= limit:
                if limit == self.size and not self.data_end_reached and not self._ends_with_magic:
                    self._cut_short(pos, "it ends after a complete record, without the rest of the file")
                return
            if pos + 9 > limit:
                self._cut_short(pos, "it ends in the middle of a record")
                return
            op, length = _OP_LEN.unpack_from(buf, pos)
            end = pos + 9 + length
            name = RECORD_NAMES.get(op, f"unknown (opcode {op:#x})")
            try:
                if pos == len(MAGIC) and op != HEADER:
                    raise _Bad("the file does not begin with a header record")
                if op in _LOOSE:
                    if end > limit:
                        raise _Bad(f"its length field ({length} bytes) runs past the end of the file")
                    if loose is None:
                        loose = _Segment(pos, end, chunked=False)
                        self._segments.append(loose)
                    loose.end = pos = end
                    continue
                loose = None
                if op == DATA_END and length == 4 and end <= limit:
                    self.data_end_reached = True
                    return
                if op in _SUMMARY_ONLY:
                    raise _Bad("a summary record inside the data section")
                if op == CHUNK:
                    seg = self._chunk_at(pos, length, limit)
                    self._segments.append(seg)
                    last_chunk, pos = seg, seg.end
                    continue
                if end > limit and op not in (HEADER, METADATA, ATTACHMENT):
                    raise _Bad(f"its length field ({length} bytes) runs past the end of the file")
                if op == MESSAGE_INDEX:
                    f = _Fields(buf, pos + 9, end)
                    cid, n = f.u16(), f.u32()
                    if n % 16 or f.pos + n != end:
                        raise _Bad("its entries do not fill its length")
                    if last_chunk is not None:
                        last_chunk.channel_ids.add(cid)
                        last_chunk.indexes.append((cid, f.pos, n))
                    pos = end
                    continue
                if op == HEADER:
                    if pos != len(MAGIC):
                        raise _Bad("a second header")
                    inner = self._parse_header(pos, min(end, limit))
                elif op == METADATA:
                    record, inner = self._parse_metadata(pos, min(end, limit))
                    self.metadata.append(record)
                    if record.repaired:
                        self._damage(f"the metadata record at byte {pos}", "its map length is wrong", "nothing")
                elif op == ATTACHMENT:
                    attachment, inner = self._parse_attachment(pos, min(end, limit))
                    self.attachments.append(attachment)
                    if attachment.repaired:
                        self._damage(
                            f"the attachment {attachment.name!r} at byte {pos}",
                            "its data size field is wrong",
                            "nothing",
                        )
                else:
                    raise _Bad("an unknown record type")
                pos = self._next_after(pos, name, end, inner, limit)
            except (_Bad, struct.error) as exc:
                at_header = pos == len(MAGIC)
                if at_header:
                    self._damage("the header", f"unreadable ({exc})", "nothing")
                found = self._resync(pos + 1, limit)
                if found is None:
                    if op in _SUMMARY_ONLY and not self.summary_ok:
                        self.notes.append(f"the data section ends at byte {pos} without a data end record")
                        self.data_end_reached = True
                    elif end > self.size and op in RECORD_NAMES and not self._ends_with_magic:
                        self._cut_short(pos, f"it ends in the middle of a {name} record")
                    else:
                        self._damage(f"byte {pos}", f"unreadable data from here on ({name} record: {exc})")
                        self._walk_damage.append((len(self.damage) - 1, pos, limit))
                    return
                if found == end and op not in RECORD_NAMES:
                    pos = found  # a record type from a newer MCAP version: skipped, as the spec says
                    continue
                if not at_header:
                    self._skipped(pos, found, name, str(exc))
                    self._walk_damage.append((len(self.damage) - 1, pos, found))
                pos = found

    def _next_after(self, pos: int, name: str, end: int, inner: int, limit: int) -> int:
        """Where the record after the one at `pos` starts: at its length field's end, unless
        that field is wrong (past the file, or onto something unreadable) and the record's own
        fields end where a readable record starts."""
        if inner == end and end <= limit:
            return end
        if end <= limit and self._starts_record(end, limit):
            return end  # padding after its fields, as newer MCAP versions may write
        if not self._starts_record(inner, limit):
            raise _Bad(f"its length field ({end - pos - 9} bytes) does not match its fields")
        self._damage(f"the {name} record at byte {pos}", "its length field is wrong; read by its fields", "nothing")
        return inner

    def _starts_record(self, pos: int, limit: int) -> bool:
        """Whether a record that parses exactly starts at `pos` (or the data section ends there)."""
        if pos == limit:
            return True
        if pos + 9 > limit:
            return False
        op, length = _OP_LEN.unpack_from(self._buf, pos)
        if op == DATA_END:
            return length == 4
        if op == MESSAGE_INDEX:
            if pos + 15 > limit:
                return False
            n = struct.unpack_from("<I", self._buf, pos + 11)[0]
            return length == 6 + n and n % 16 == 0 and pos + 9 + length <= limit
        return self._resync(pos, pos + 1, limit) == pos

    def _parse_header(self, pos: int, end: int) -> int:
        f = _Fields(self._buf, pos + 9, end)
        self.profile, self.library = f.text(), f.text()
        self.has_header = True
        return f.pos

    def _cut_short(self, pos: int, why: str) -> None:
        self._damage(_END, f"cut short at byte {pos} ({why})", "messages", span_ns=None)

    def _skipped(self, pos: int, found: int, name: str, why: str) -> None:
        where = f"the {name} record at byte {pos}" if not name.startswith("unknown") else f"byte {pos}"
        loses = {"metadata": "metadata", "attachment": "an attachment", "message index": "nothing"}.get(
            name, "messages"
        )
        self._damage(where, f"unreadable ({why}); reading resumed at byte {found}", loses)

    def _resync(self, start: int, stop: int, limit: int | None = None) -> int | None:
        """The first offset in [start, stop) where a chunk, metadata or attachment record
        parses exactly (its end within `limit`, default `stop`), if any."""
        limit = stop if limit is None else limit
        for m in _RESYNC.finditer(self._buf, start, stop):
            pos = m.start()
            if pos + 9 > limit:
                return None
            op, length = _OP_LEN.unpack_from(self._buf, pos)
            end = pos + 9 + length
            if end > limit:
                continue
            try:
                if op == CHUNK:
                    self._parse_chunk(pos, length, limit, exact=True)
                elif op == METADATA:
                    if self._parse_metadata(pos, end)[1] != end:
                        continue
                else:
                    self._parse_attachment(pos, end, require_crc=True)
            except (_Bad, struct.error):
                continue
            return pos
        return None

    def _parse_chunk(self, pos: int, length: int, limit: int, exact: bool = False) -> _Segment:
        """A chunk's fields. Its records are located by its records length field, or by its
        record length where the two disagree (each is a reading the CRC will judge)."""
        body = pos + 9
        record_end = body + length
        f = _Fields(self._buf, body, min(record_end, limit))
        t0, t1, usize, crc = f.u64(), f.u64(), f.u64(), f.u32()
        compression = f.text()
        if len(compression) > 16 or (exact and compression not in COMPRESSIONS):
            raise _Bad(f"an unknown compression {compression[:16]!r}")
        records_len = f.u64()
        records_at = f.pos
        readings = []
        if records_at + records_len <= limit:
            readings.append((compression, records_at, records_len, usize, crc))
        note = ""
        if records_at + records_len != record_end:
            if exact:
                raise _Bad("its records length disagrees with its length")
            note = "its two length fields disagree; read by the one its CRC confirms"
            if record_end <= limit:
                readings.append((compression, records_at, record_end - records_at, usize, crc))
        if not readings:
            raise _Bad("its records run past the end of the file")
        end = readings[0][1] + readings[0][2]
        return _Segment(
            pos, end, chunked=True, start_ns=t0, end_ns=t1, readings=readings, note=note, header_span=(t0, t1)
        )

    def _chunk_at(self, pos: int, length: int, limit: int) -> _Segment:
        """The chunk at `pos`, in the walk: where its two length fields disagree, the one whose
        reading passes the CRC says where the next record starts."""
        seg = self._parse_chunk(pos, length, limit)
        if seg.note:
            for reading in seg.readings:
                try:
                    self._records_of(seg, reading)
                except _Bad:
                    continue
                seg.readings.remove(reading)
                seg.readings.insert(0, reading)
                seg.end = reading[1] + reading[2]
                break
        return seg

    def _parse_metadata(self, pos: int, end: int) -> tuple[MetadataRecord, int]:
        """A metadata record, and where its fields end. A map length that runs past the record
        is not trusted: the entries are read up to the record's end."""
        f = _Fields(self._buf, pos + 9, end)
        name = f.text()
        mark = f.pos
        try:
            return MetadataRecord(name, f.text_map(), pos), f.pos
        except _Bad:
            f.pos = mark + 4
            entries = {}
            while f.pos < f.end:
                key = f.text()
                entries[key] = f.text()
            return MetadataRecord(name, entries, pos, repaired=True), f.pos

    def _parse_attachment(self, pos: int, end: int, require_crc: bool = False) -> tuple[AttachmentRecord, int]:
        """An attachment whose CRC holds, and where its fields end. Where its data size field
        disagrees with the record's length, the size the CRC confirms is taken."""
        f = _Fields(self._buf, pos + 9, end)
        log_time, create_time, name, media = f.u64(), f.u64(), f.text(), f.text()
        size = f.u64()
        data_at = f.pos
        sizes = [size] if data_at + size + 4 <= end else []
        if end - data_at - 4 not in sizes and end - data_at >= 4:
            sizes.append(end - data_at - 4)
        for candidate in sizes:
            crc = struct.unpack_from("<I", self._buf, data_at + candidate)[0]
            if crc == 0 and (require_crc or candidate != size):
                continue  # nothing to confirm it by
            # the CRC covers the size field too: check it as the size it should have had
            fields = self._buf[pos + 9 : data_at - 8] + struct.pack("<Q", candidate)
            if crc and zlib.crc32(self._buf[data_at : data_at + candidate], zlib.crc32(fields)) != crc:
                continue
            record = AttachmentRecord(name, media, log_time, create_time, pos, data_at, candidate, candidate != size)
            return record, data_at + candidate + 4
        raise _Bad("its CRC does not match" if sizes else "its data runs past the end of the record")

    def _add_indexed(self) -> None:
        """What only the summary's indexes reach (past a damaged length field)."""
        s = self._summary
        if not s.chunk_indexes and not s.attachment_offsets and not s.metadata_offsets:
            return
        known = {seg.offset: seg for seg in self._segments}
        for t0, t1, offset, chunk_len, ids, compression, compressed, uncompressed in s.chunk_indexes:
            seg = known.get(offset)
            if seg is not None:
                seg.start_ns, seg.end_ns = t0, t1  # the summary's CRC vouches for these
                seg.channel_ids |= ids
                continue
            end = offset + chunk_len
            if not len(MAGIC) <= offset < end <= self.size or compressed > chunk_len:
                continue
            seg = _Segment(offset, end, chunked=True, start_ns=t0, end_ns=t1, channel_ids=set(ids))
            if chunk_len < 9 + 40:
                continue
            try:
                seg.readings = self._parse_chunk(offset, chunk_len - 9, end).readings
            except (_Bad, struct.error):
                pass
            # the index's own sizes locate the records even when the chunk's fields are damaged
            crc = struct.unpack_from("<I", self._buf, offset + 9 + 24)[0] if offset + 9 + 28 <= end else 0
            reading = (compression, end - compressed, compressed, uncompressed, crc)
            if reading not in seg.readings:
                seg.readings.append(reading)
            self._segments.append(seg)
            known[offset] = seg
        have = {m.offset for m in self.metadata} | {a.offset for a in self.attachments}
        for offset, is_metadata in [(o, True) for o in s.metadata_offsets] + [(o, False) for o in s.attachment_offsets]:
            if offset in have or not len(MAGIC) <= offset <= self.size - 9:
                continue
            end = offset + 9 + _OP_LEN.unpack_from(self._buf, offset)[1]
            if end > self.size:
                continue
            try:
                if is_metadata:
                    self.metadata.append(self._parse_metadata(offset, end)[0])
                else:
                    self.attachments.append(self._parse_attachment(offset, end)[0])
            except (_Bad, struct.error):
                continue
        self.metadata.sort(key=lambda m: m.offset)
        self.attachments.sort(key=lambda a: a.offset)

    # --- reading the records ---------------------------------------------------------------------

    def _records_of(self, seg: _Segment, reading: tuple[str, int, int, int, int]) -> bytes:
        compression, at, length, usize, crc = reading
        payload = self._buf[at : at + length]
        limit = max(MAX_RATIO * length, MIN_LIMIT_BYTES)
        if compression == "":
            raw = bytes(payload)
        elif compression == "zstd":
            raw = _unzstd(bytes(payload), limit)
        elif compression == "lz4":
            raw = _unlz4(bytes(payload), limit)
        else:
            raise _Bad(f"an unknown compression {compression[:16]!r}")
        if seg.chunked and crc and zlib.crc32(raw) != crc:
            raise _Bad("its CRC does not match (the data is damaged)")
        if seg.chunked and not crc and len(raw) != usize:
            raise _Bad("it does not decompress to its stated size")
        return raw

    def _first_pass(self) -> None:
        channels: dict[int, int] = {}
        schemas: dict[int, SchemaDef] = {}
        for seg in self._segments:
            seg.channels_at_start, seg.schemas_at_start = dict(channels), dict(schemas)
            problem = "it has no readable records" if not seg.readings else ""
            for index, reading in enumerate(seg.readings):
                try:
                    raw = self._records_of(seg, reading)
                except _Bad as exc:
                    problem = problem or str(exc)
                    continue
                seg.ok, seg.reading = True, index
                break
            if not seg.ok:
                self._chunk_damage(seg, problem, channels)
                continue
            if seg.note:
                self._damage(f"the chunk at byte {seg.offset}", seg.note, "nothing")
            if seg.readings[seg.reading][3] != len(raw) and seg.chunked:
                self._damage(
                    f"the chunk at byte {seg.offset}",
                    f"its uncompressed size field is wrong ({seg.readings[seg.reading][3]}, holds {len(raw)} bytes)",
                    "nothing",
                )
            found: dict[int, list[tuple[int, int]]] = {}
            for _ in self._parse_segment(seg, raw, set(), first_pass=True, state=(channels, schemas), found=found):
                pass
            self._check_indexes(seg, found)
            times = [t for entries in found.values() for t, _ in entries]
            if times and seg.header_span is not None and seg.header_span != (min(times), max(times)):
                self._damage(f"the chunk at byte {seg.offset}", "its time range fields are wrong", "nothing")
        if self.orphans:
            self._damage(
                "channel records",
                f"{self.orphans} messages are on channels whose definition is lost or unreadable: skipped",
                "messages",
            )

    def _resolve_walk_damage(self) -> None:
        """Records skipped in the walk cost nothing when the summary's index reached everything
        the skipped bytes held."""
        s = self._summary
        if not self.summary_ok or not (s.chunk_indexes or s.metadata_offsets or s.attachment_offsets):
            return
        read = {seg.offset for seg in self._segments if seg.ok}
        read |= {m.offset for m in self.metadata} | {a.offset for a in self.attachments}
        indexed = [c[2] for c in s.chunk_indexes] + s.metadata_offsets + s.attachment_offsets
        for index, start, stop in self._walk_damage:
            if all(offset in read for offset in indexed if start <= offset < stop):
                d = self.damage[index]
                self.damage[index] = replace(
                    d, why=d.why + "; the summary's index reached everything after it", loses="nothing"
                )

    def _check_indexes(self, seg: _Segment, found: dict[int, list[tuple[int, int]]]) -> None:
        """A chunk's message indexes must list exactly its messages (damage there costs nothing)."""
        if not seg.indexes:
            return
        listed: dict[int, list[tuple[int, int]]] = {}
        for cid, at, n in seg.indexes:
            listed.setdefault(cid, []).extend(struct.iter_unpack("<QQ", self._buf[at : at + n]))
        if {k: sorted(v) for k, v in listed.items()} != {k: sorted(v) for k, v in found.items()}:
            self._damage(
                f"the message index of the chunk at byte {seg.offset}",
                "it does not match the chunk's messages",
                "nothing",
            )

    def _chunk_damage(self, seg: _Segment, why: str, channels: dict[int, int]) -> None:
        ids = seg.channel_ids
        topics: tuple[str, ...] | None = None
        if ids:
            names = set()
            for cid in ids:
                if cid in channels:
                    names.add(self.channels[channels[cid]].topic)
                elif cid in self._summary.channels:
                    names.add(self._summary.channels[cid][1])
            topics = tuple(sorted(names)) or None
        start, end = seg.start_ns, seg.end_ns  # its own fields (or the summary's index, when sound)
        if start > end:  # those fields are damaged too: the span between its neighbours
            before = [s.end_ns for s in self._segments if s.ok and s.offset < seg.offset and s.counts]
            after = [s.start_ns for s in self._segments if s.offset > seg.offset]
            start = max(before, default=0)
            end = max(start, min(after, default=start))
        what = "chunk" if seg.chunked else "records"
        self._damage(f"the {what} at byte {seg.offset}", why, "messages", span_ns=(start, end), topics=topics)

    def _parse_segment(
        self,
        seg: _Segment,
        raw: bytes,
        keys: set[int] | None,
        first_pass: bool,
        state: tuple[dict[int, int], dict[int, SchemaDef]] | None = None,
        found: dict[int, list[tuple[int, int]]] | None = None,
    ) -> Iterator[RawMessage]:
        """The records of one chunk (or run of unchunked records), in order; yields the
        messages of channels in `keys` (all: None). The first pass defines channels and counts.

        It is one piece for the reason `_walk` is, and because it is a generator: the position, the
        channels defined so far and the damage noted are one state that the branches share."""
        channels, schemas = state if state is not None else (dict(seg.channels_at_start), dict(seg.schemas_at_start))
        new_channel = 0
        pos, n = 0, len(raw)
        where = f"the {'chunk' if seg.chunked else 'records'} at byte {seg.offset}"
        while pos < n:
            if pos + 9 > n:
                if first_pass:
                    self._damage(where, "its last record is cut off: skipped", "messages")
                return
            op, length = _OP_LEN.unpack_from(raw, pos)
            body, end = pos + 9, pos + 9 + length
            if end > n:
                if first_pass:
                    self._damage(where, f"a record at {pos} runs past its end; the rest of it is skipped", "messages")
                return
            pos = end
            if op == MESSAGE:
                if length < _MESSAGE_HEAD.size:
                    continue
                cid, seq, log_time, publish_time = _MESSAGE_HEAD.unpack_from(raw, body)
                if found is not None:
                    found.setdefault(cid, []).append((log_time, pos - 9 - length))
                key = channels.get(cid)
                if key is None:
                    key = self._summary_channel(cid, schemas) if first_pass else self._summary_keys.get(cid)
                if key is None:
                    if first_pass:
                        self.orphans += 1
                    continue
                if first_pass:
                    seg.counts[key] = seg.counts.get(key, 0) + 1
                    if seg.first_message_ns is None or log_time < seg.first_message_ns:
                        seg.first_message_ns = log_time
                    self.counts[key] = self.counts.get(key, 0) + 1
                    if key not in self.first_ns or log_time < self.first_ns[key]:
                        self.first_ns[key] = log_time
                    if key not in self.last_ns or log_time > self.last_ns[key]:
                        self.last_ns[key] = log_time
                elif keys is None or key in keys:
                    yield RawMessage(self.channels[key], seq, log_time, publish_time, raw[body + 22 : end])
            elif op == SCHEMA:
                try:
                    f = _Fields(raw, body, end)
                    sid, name, enc, data = f.u16(), f.text(), f.text(), f.take(f.u32())
                except _Bad as exc:
                    if first_pass:
                        self.notes.append(f"{where}: a schema record is unreadable ({exc}); skipped")
                    continue
                if first_pass and sid in schemas and schemas[sid] != SchemaDef(sid, name, enc, data):
                    self.notes.append(f"schema id {sid} is defined again differently ({schemas[sid].name} -> {name})")
                if sid != 0:
                    schemas[sid] = SchemaDef(sid, name, enc, data)
            elif op == CHANNEL:
                try:
                    f = _Fields(raw, body, end)
                    cid, sid, topic, enc, md = f.u16(), f.u16(), f.text(), f.text(), f.text_map()
                except _Bad as exc:
                    if first_pass:
                        self.notes.append(f"{where}: a channel record is unreadable ({exc}); its messages are skipped")
                    channels.pop(struct.unpack_from("<H", raw, body)[0] if length >= 2 else -1, None)
                    continue
                if first_pass:
                    key = self._define(cid, sid, topic, enc, md, schemas, channels)
                    seg.new_keys.append(key)
                else:
                    key = seg.new_keys[new_channel]
                new_channel += 1
                channels[cid] = key

    def _define(
        self,
        cid: int,
        sid: int,
        topic: str,
        enc: str,
        md: dict[str, str],
        schemas: dict[int, SchemaDef],
        channels: dict[int, int],
    ) -> int:
        schema = schemas.get(sid) if sid else None
        if schema is None and sid and sid in self._summary.schemas:
            schema = self._summary.schemas[sid]
        old = self.channels[channels[cid]] if cid in channels else None
        if old is not None and (old.topic, old.message_encoding, old.schema) == (topic, enc, schema):
            return old.key
        if old is not None:
            self.notes.append(f"channel id {cid} is defined again, for {topic!r} (was {old.topic!r})")
        key = len(self.channels)
        self.channels.append(ChannelDef(key, cid, topic, enc, md, schema))
        return key

    def _summary_channel(self, cid: int, schemas: dict[int, SchemaDef]) -> int | None:
        """The summary's definition of a channel whose own record was lost."""
        if cid in self._summary_keys:
            return self._summary_keys[cid]
        found = self._summary.channels.get(cid)
        if found is None:
            return None
        sid, topic, enc, md = found
        schema = self._summary.schemas.get(sid) or schemas.get(sid)
        key = len(self.channels)
        self.channels.append(ChannelDef(key, cid, topic, enc, md, schema))
        self._summary_keys[cid] = key
        self.notes.append(
            f"channel {topic!r}: no readable record defines it before its messages; the summary's is used"
        )
        return key


def _unzstd(payload: bytes, limit: int) -> bytes:
    """Decompress at most `limit` bytes (more is damage), reading in pieces: nothing is
    allocated from a size field."""
    import zstandard

    out = bytearray()
    try:
        reader = zstandard.ZstdDecompressor().stream_reader(payload)
        while True:
            piece = reader.read(min(1 << 20, limit + 1 - len(out)) or 1)
            if not piece:
                break
            out += piece
            if len(out) > limit:
                raise _Bad(f"it decompresses to more than {limit} bytes")
    except zstandard.ZstdError as exc:
        raise _Bad(f"it does not decompress ({exc})") from None
    return bytes(out)


def _unlz4(payload: bytes, limit: int) -> bytes:
    import lz4.frame  # type: ignore[import-untyped]

    try:
        d = lz4.frame.LZ4FrameDecompressor()
        out = d.decompress(payload, max_length=limit + 1)
    except RuntimeError as exc:
        raise _Bad(f"it does not decompress ({exc})") from None
    if len(out) > limit:
        raise _Bad(f"it decompresses to more than {limit} bytes")
    return bytes(out)
