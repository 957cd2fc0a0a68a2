"""Live bridges: a run's topics streamed to outside viewers and programs while it flies, and
commands taken back from them (Foxglove WebSocket; ROS 2). Each is a consumer of the topic
fan-out, so it sees exactly what a recording gets. This module loads no bridge."""

#: where --foxglove serves when given no HOST:PORT: this machine only
FOXGLOVE_DEFAULT_HOST = "127.0.0.1"
FOXGLOVE_DEFAULT_PORT = 8765
FOXGLOVE_DEFAULT_ENDPOINT = f"{FOXGLOVE_DEFAULT_HOST}:{FOXGLOVE_DEFAULT_PORT}"
