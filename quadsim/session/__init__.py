"""The run session, below the apps: how every run is flown.

A run's plan (`plan`: config, vehicles with their drivers and cameras, duration, outputs, live
bridges) is opened as a Run (`run`: the fleet built, its outputs attached) and flown to its end
or stepped by a window, paced to the wall clock by the one pacer (`pacing`), then summarised
(`summary`). Its outputs record it (cameras, the topic fan-out and the MCAP recorder, finished
together on any exit: `outputs`) and serve it on the live bridges (`live`); a recording is flown
again as a plan too (`resim`). SIGINT and SIGTERM become stop requests every loop honours
(`stopping`), with progress shown on the way (`progress`). Every command of `quadsim.apps`
builds on these; nothing here imports the apps.
"""
