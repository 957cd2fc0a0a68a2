"""The render worker process: a CameraRig of its own, answering render jobs over a pipe.

Started as `python -m quadsim.sensors.render_worker FD` (not through multiprocessing's spawn, which
would re-run the user's __main__ module), FD being its end of a socket pair the parent made; it
receives its settings as the first message. It runs in a session of its own, so Ctrl-C and
signals to the parent's process group are the parent's to act on; it exits when the parent
says so or goes away (end of file), so it never outlives the parent.

Protocol (parent -> worker): (seq, step, names, position, orientation, image kinds, companion
poses), or None to stop; the companions (a fleet's other vehicles) are named in the settings.
Worker -> parent: ("ready",) once set up, then (seq, [CameraFrame, ...]) per job, or
("error", message) if it cannot go on.
"""

from __future__ import annotations

import contextlib
import os
import signal
import sys
import traceback
from multiprocessing.connection import Connection
from pathlib import Path


def worker_main(conn: Connection, settings: dict) -> None:
    """Build the rig `settings` describe (CameraPipeline's), say ready, then render each job."""
    try:
        from quadsim.physics.world_spec import load_world
        from quadsim.sensors.camera import RendererKind
        from quadsim.sensors.rig import CameraRig
        from quadsim.vehicle.params import load_vehicle

        rig = CameraRig.standalone(
            load_vehicle(Path(settings["urdf"]), Path(settings["params"])),
            load_world(Path(settings["world"])),
            settings["specs"],
            RendererKind(settings["renderer"]),
            tuple(load_vehicle(Path(u), Path(p)) for u, p in settings.get("companions", ())),
            int(settings.get("own_index", 0)),
        )
    except Exception as exc:  # report, do not die silently
        conn.send(("error", f"{type(exc).__name__}: {exc}"))
        return
    conn.send(("ready",))
    try:
        while True:
            job = conn.recv()
            if job is None:
                break
            seq, step, names, position, orientation, kinds, companion_poses = job
            conn.send((seq, rig.render(names, step, position, orientation, kinds, companion_poses)))
    except (EOFError, KeyboardInterrupt, OSError):
        pass  # the parent went away or was interrupted: nothing to report to
    except Exception:
        with contextlib.suppress(OSError):  # BrokenPipeError too: gone, nothing to report to
            conn.send(("error", traceback.format_exc(limit=3)))
    finally:
        rig.close()


def main() -> None:
    # Ctrl-C, SIGTERM and SIGHUP reach the whole process group: let the parent decide when the worker
    # stops, so it can still collect the frames in flight and finish its recording
    for name in ("SIGINT", "SIGTERM", "SIGHUP"):  # (a closed terminal's SIGHUP too)
        if hasattr(signal, name):
            signal.signal(getattr(signal, name), signal.SIG_IGN)
    conn = Connection(int(sys.argv[1]))
    try:
        settings = conn.recv()
    except (EOFError, OSError):
        return  # the parent went away before it could say anything
    if settings.get("renderer") == "egl":  # the EGL plugin prints GL strings on stdout as it renders
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, 1)
        os.close(devnull)
    niceness = settings.get("niceness", 0)
    if niceness:
        with contextlib.suppress(OSError):
            os.nice(niceness)  # the window and the flight come first on a busy machine
    worker_main(conn, settings)
    conn.close()


if __name__ == "__main__":
    main()
