"""Salvaging a damaged or cut-short MCAP file: `recover` writes every readable message to a new,
valid, indexed MCAP.

A recording killed mid-run (SIGKILL, power loss) has its header and every chunk flushed so far,
but no summary, index or footer; a file damaged on disk has chunks that fail their CRC, indexes
or a summary that no longer match, length fields gone absurd. `mcap_scan` reads such a file chunk
by chunk: every chunk whose CRC holds is kept, a damaged one is skipped, the data section is
trusted over a damaged summary, and reading resumes after an absurd length at the next record
that parses (or where the summary's index points). The output is written to a temporary file
beside the target and moved into place only once finished: a full disk leaves nothing behind.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from mcap.writer import CompressionType, Writer

from quadsim.core.files import write_whole
from quadsim.errors import QuadsimError
from quadsim.recording.mcap_scan import Damage, McapFile, SchemaDef


@dataclass(frozen=True)
class Recovered:
    path: Path
    messages: int
    topics: int
    chunks: int
    span_s: tuple[float, float]
    was_complete: bool
    damage: tuple[Damage, ...] = ()
    attachments: int = 0
    metadata: int = 0


def recover(src: Path, dst: Path | None = None, required_topics: tuple[str, ...] = ()) -> Recovered:
    """Write every readable message, metadata record and attachment of `src` into a new indexed
    MCAP (default SRC.recovered.mcap). Nothing is overwritten.

    With `required_topics`, refuse a file that has none of them (someone else's MCAP)."""
    out = dst if dst is not None else src.with_name(src.stem + ".recovered.mcap")
    with McapFile(src) as f:
        if out.exists():
            raise QuadsimError(_already(out))
        if out.resolve() == src.resolve():
            raise QuadsimError("the output must be a different file from the input")
        if not f.message_count:
            why = "; ".join(d.describe() for d in f.damage) or "it holds no messages"
            raise QuadsimError(f"{src}: no complete message could be read ({why}); nothing to recover")
        topics = {ch.topic for ch in f.channels if f.counts.get(ch.key)}
        if required_topics and not topics & set(required_topics):
            raise QuadsimError(
                f"{src}: has none of a quadsim recording's topics (found {', '.join(sorted(topics)) or 'none'}); "
                f"it is someone else's MCAP file: nothing written"
            )
        written: list[tuple[int, int, int]] = []
        try:
            write_whole(out, lambda fh: written.append(_write(f, fh)), _already(out))
        except OSError as exc:
            raise QuadsimError(f"cannot write {out}: {exc.strerror or exc}; nothing was written") from None
        (counts,) = written
        t0, t1 = f.span_ns
        return Recovered(
            out,
            counts[0],
            len(topics),
            f.chunk_count,
            (t0 / 1e9, t1 / 1e9),
            f.complete,
            tuple(f.damage),
            counts[1],
            counts[2],
        )


def _already(out: Path) -> str:
    return f"{out} already exists; choose another -o (nothing is overwritten)"


def _write(f: McapFile, fh: object) -> tuple[int, int, int]:
    """Copy what `f` holds to a new MCAP on `fh`, chunk by chunk; (messages, attachments,
    metadata records) written."""
    writer = Writer(fh, compression=CompressionType.ZSTD)  # type: ignore[arg-type]
    profile = f.profile
    if not f.has_header and f.channels and all(ch.message_encoding == "cdr" for ch in f.channels):
        profile = "ros2"  # the header is lost, but its messages say what it was
    writer.start(profile=profile, library=f.library or "quadsim recover")
    for md in f.metadata:
        writer.add_metadata(md.name, md.metadata)
    for at in f.attachments:
        writer.add_attachment(at.create_time, at.log_time, at.name, at.media_type, f.attachment_data(at))
    schema_ids: dict[SchemaDef, int] = {}
    channel_ids: dict[int, int] = {}  # channel key -> id in the output
    kept = 0
    for msg in f.messages(log_time_order=False):
        ch = msg.channel
        if ch.key not in channel_ids:
            sid = 0
            if ch.schema is not None:
                if ch.schema not in schema_ids:
                    s = ch.schema
                    schema_ids[s] = writer.register_schema(s.name, s.encoding, s.data)
                sid = schema_ids[ch.schema]
            channel_ids[ch.key] = writer.register_channel(ch.topic, ch.message_encoding, sid, ch.metadata)
        writer.add_message(channel_ids[ch.key], msg.log_time, msg.data, msg.publish_time, msg.sequence)
        kept += 1
    writer.finish()
    return kept, len(f.attachments), len(f.metadata)
