"""Reading what can be read from an MCAP file that was cut short, and writing it out indexed.

A recording killed mid-run (SIGKILL, power loss) has its header and every chunk flushed so far,
but no summary, index or footer. `scan` walks the file record by record, keeps each complete
chunk whose CRC holds, and stops at the first record that is cut off; `recover` writes what it
found to a new, valid, indexed MCAP.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from mcap.exceptions import McapError
from mcap.records import Attachment, Channel, Chunk, Footer, Header, Message, Metadata, Schema
from mcap.stream_reader import StreamReader, breakup_chunk
from mcap.writer import CompressionType, Writer

from quadsim.errors import QuadsimError

MCAP_MAGIC = b"\x89MCAP0\r\n"


def check_is_mcap(path: Path) -> None:
    """Raise QuadsimError unless `path` is a readable file starting with the MCAP magic."""
    if not path.exists():
        raise QuadsimError(f"{path}: no such file")
    if not path.is_file():
        raise QuadsimError(f"{path}: not a file")
    try:
        with open(path, "rb") as fh:
            head = fh.read(len(MCAP_MAGIC))
    except OSError as exc:
        raise QuadsimError(f"{path}: cannot read ({exc.strerror})") from None
    if not head:
        raise QuadsimError(f"{path}: empty file (0 bytes), not an MCAP recording")
    if head != MCAP_MAGIC[: len(head)] or len(head) < len(MCAP_MAGIC):
        raise QuadsimError(f"{path}: not an MCAP file (it does not start with the MCAP magic bytes)")


@dataclass
class Scan:
    """What a sequential read of a file found."""

    header: Header | None = None
    schemas: dict[int, Schema] = field(default_factory=dict)
    channels: dict[int, Channel] = field(default_factory=dict)
    messages: list[Message] = field(default_factory=list)
    metadata: list[Metadata] = field(default_factory=list)
    attachments: list[Attachment] = field(default_factory=list)
    complete_chunks: int = 0
    bad_chunks: int = 0
    complete: bool = False  # a footer was reached
    stop_reason: str = ""

    @property
    def span_s(self) -> tuple[float, float]:
        if not self.messages:
            return (0.0, 0.0)
        times = [m.log_time for m in self.messages]
        return (min(times) / 1e9, max(times) / 1e9)


def _take(record: object, scan: Scan) -> None:
    if isinstance(record, Schema):
        scan.schemas[record.id] = record
    elif isinstance(record, Channel):
        scan.channels[record.id] = record
    elif isinstance(record, Message):
        scan.messages.append(record)


def scan(path: Path) -> Scan:
    check_is_mcap(path)
    result = Scan()
    with open(path, "rb") as fh:
        reader = StreamReader(fh, emit_chunks=True, record_size_limit=1 << 30)
        try:
            for record in reader.records:
                if isinstance(record, Header):
                    result.header = record
                elif isinstance(record, Chunk):
                    try:
                        inner = list(breakup_chunk(record, validate_crc=True))
                    except (McapError, ValueError) as exc:
                        result.bad_chunks += 1
                        result.stop_reason = f"a damaged chunk was skipped ({exc})"
                        continue
                    result.complete_chunks += 1
                    for item in inner:
                        _take(item, result)
                elif isinstance(record, Metadata):
                    result.metadata.append(record)
                elif isinstance(record, Attachment):
                    result.attachments.append(record)
                elif isinstance(record, Footer):
                    result.complete = True
                else:
                    _take(record, result)
        except McapError as exc:
            result.stop_reason = f"the file ends in the middle of a record ({type(exc).__name__})"
        except Exception as exc:  # a malformed record: anything the record parsers raise
            result.stop_reason = f"unreadable data after {result.complete_chunks} chunks ({type(exc).__name__}: {exc})"
    if result.header is None:
        raise QuadsimError(f"{path}: MCAP magic but no readable header; nothing can be recovered")
    return result


def damage_report(path: Path) -> str:
    """What is wrong with a file that has no readable summary, and how much of it is readable."""
    found = scan(path)
    if found.complete and not found.messages:
        return f"{path}: a complete MCAP file with no messages"
    t0, t1 = found.span_s
    why = found.stop_reason or "it has no summary section"
    return (
        f"{path}: damaged or cut short: {why}. Readable: {len(found.messages)} messages in "
        f"{found.complete_chunks} complete chunks, {t0:.2f} .. {t1:.2f} s"
        + (f", {found.bad_chunks} damaged chunks skipped" if found.bad_chunks else "")
        + f". Run 'quadsim recover {path}' to save them to an indexed file."
    )


@dataclass(frozen=True)
class Recovered:
    path: Path
    messages: int
    topics: int
    chunks: int
    span_s: tuple[float, float]
    was_complete: bool
    note: str


def recover(src: Path, dst: Path | None = None, required_topics: tuple[str, ...] = ()) -> Recovered:
    """Write every complete message of `src` into a new indexed MCAP (default SRC.recovered.mcap).

    With `required_topics`, refuse a file that has none of them (someone else's MCAP)."""
    found = scan(src)
    out = dst if dst is not None else src.with_name(src.stem + ".recovered.mcap")
    if out.exists():
        raise QuadsimError(f"{out} already exists; choose another -o (nothing is overwritten)")
    if out.resolve() == src.resolve():
        raise QuadsimError("the output must be a different file from the input")
    if not found.messages:
        raise QuadsimError(
            f"{src}: no complete message could be read ({found.stop_reason or 'no chunks'}); nothing to recover"
        )
    topics = {ch.topic for ch in found.channels.values()}
    if required_topics and not topics & set(required_topics):
        raise QuadsimError(
            f"{src}: has none of a quadsim recording's topics (found {', '.join(sorted(topics)) or 'none'}); "
            f"nothing written"
        )
    try:
        fh = open(out, "xb")
    except OSError as exc:
        raise QuadsimError(f"cannot create {out}: {exc.strerror}") from None
    with fh:
        writer = Writer(fh, compression=CompressionType.ZSTD)
        writer.start(profile=found.header.profile, library=found.header.library or "quadsim recover")  # type: ignore[union-attr]
        schema_ids = {sid: writer.register_schema(s.name, s.encoding, s.data) for sid, s in found.schemas.items()}
        channel_ids = {}
        for cid, ch in found.channels.items():
            channel_ids[cid] = writer.register_channel(
                ch.topic, ch.message_encoding, schema_ids.get(ch.schema_id, 0), ch.metadata
            )
        for md in found.metadata:
            writer.add_metadata(md.name, md.metadata)
        for at in found.attachments:
            writer.add_attachment(at.log_time, at.create_time, at.name, at.media_type, at.data)
        kept = 0
        for msg in found.messages:
            if msg.channel_id in channel_ids:
                writer.add_message(channel_ids[msg.channel_id], msg.log_time, msg.data, msg.publish_time, msg.sequence)
                kept += 1
        writer.finish()
    topic_count = len({found.channels[m.channel_id].topic for m in found.messages if m.channel_id in found.channels})
    return Recovered(out, kept, topic_count, found.complete_chunks, found.span_s, found.complete, found.stop_reason)
