"""The run session, below the apps: what one run is made of besides the simulator.

A session records a run (cameras, the topic fan-out and the MCAP recorder, finished together on
any exit: `outputs`), opens the live bridges the run is served on (`live`), flies it headless
(`headless`) or again from a recording (`resim`), and turns SIGINT and SIGTERM into stop
requests that every loop honours (`stopping`), with progress shown on the way (`progress`).
Every command of `quadsim.apps` builds on these; nothing here imports the apps.
"""
