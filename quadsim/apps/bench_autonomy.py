"""`bench --section autonomy`: what code that reads the cameras pays, in both camera modes.

- SYNC: the cost per frame added to stepping, against the bare getCameraImage call of the same
  camera measured in the same run (the baseline);
- PIPELINED: how old the newest frame is when code reads it, with the simulation paced to real
  time (as a live robot program would be), in ms of simulation time;
- the Gymnasium environments (with the `gym` extra): env steps per second at the 30 Hz agent
  rate, one env and gymnasium.make_vec over two processes, random actions.
"""

from __future__ import annotations

import time
from collections.abc import Callable

from quadsim.core.types import Twist, ZMode
from quadsim.physics.pybullet_quiet import pb
from quadsim.sensors.camera import CameraSpec
from quadsim.sensors.rendering import projection_matrix, view_matrix
from quadsim.sim.cameras import CameraMode, Cameras
from quadsim.sim.config import SimConfig
from quadsim.sim.simulator import Simulator

FRONT = CameraSpec("front", "front_camera_link", 320, 240, rate_hz=30)


def _hovering(z_mode: ZMode = ZMode.HEIGHT) -> Simulator:
    sim = Simulator(SimConfig(z_mode=z_mode))
    sim.send(Twist())  # hold 2.0 m
    sim.run_for(3.0)
    return sim


def _seconds(run: Callable[[], object], repeats: int) -> float:
    best = float("inf")
    for _ in range(repeats):
        start = time.perf_counter()
        run()
        best = min(best, time.perf_counter() - start)
    return best


def sync_cost_per_frame(frames: int = 60, repeats: int = 3) -> tuple[float, float]:
    """(bare getCameraImage s/frame, SYNC cameras' added s/frame) for the front camera at 320x240."""
    from quadsim.sensors.camera import camera_pose

    with _hovering() as sim:
        steps = frames * (sim.config.rates.physics_hz // FRONT.rate_hz)
        state = sim.state
        pose = camera_pose(sim.vehicle.camera_mount(FRONT.link_name), state.position_m, state.orientation_xyzw)
        view, proj, cid = view_matrix(pose), projection_matrix(FRONT), sim.scene_client

        def bare() -> None:
            for _ in range(frames):
                pb.getCameraImage(320, 240, view, proj, renderer=pb.ER_TINY_RENDERER, physicsClientId=cid)

        stepping = _seconds(lambda: sim.step(steps), repeats)
        baseline = _seconds(bare, repeats)
        with Cameras(sim, (FRONT,)):
            with_cameras = _seconds(lambda: sim.step(steps), repeats)
    return baseline / frames, (with_cameras - stepping) / frames


def pipelined_frame_age(wall_s: float = 5.0, workers: int = 2) -> tuple[float, float, int, int]:
    """Paced to real time, the front camera read every camera period: (mean age ms, max age ms,
    frames read, captures dropped)."""
    with _hovering() as sim, Cameras(sim, (FRONT,), CameraMode.PIPELINED, render_workers=workers) as cams:
        cams.wait()
        period = sim.config.rates.physics_hz // FRONT.rate_hz
        ages: list[int] = []
        start, start_step = time.perf_counter(), sim.step_count
        while time.perf_counter() - start < wall_s:
            sim.step(period)
            ahead = (sim.step_count - start_step) / sim.config.rates.physics_hz - (time.perf_counter() - start)
            if ahead > 0:
                time.sleep(ahead)  # pacing, as a window or a live bridge does
            age = cams.frame_age_steps("front")
            if age is not None:
                ages.append(age)
        to_ms = 1e3 / sim.config.rates.physics_hz
        return sum(ages) / len(ages) * to_ms, max(ages) * to_ms, len(ages), cams.frames_dropped


def env_steps_per_s(env_id: str, num_envs: int, steps: int = 300) -> float:
    """Env steps per second (summed over the envs), random actions, after one reset."""
    import gymnasium as gym
    import numpy as np

    import quadsim.envs  # noqa: F401 - registers the environments

    if num_envs == 1:
        env = gym.make(env_id)
        env.reset(seed=0)
        env.action_space.seed(0)
        start = time.perf_counter()
        for _ in range(steps):
            if any(env.step(env.action_space.sample())[2:4]):
                env.reset()
        elapsed = time.perf_counter() - start
        env.close()
        return steps / elapsed
    envs = gym.make_vec(env_id, num_envs=num_envs, vectorization_mode="async")
    envs.reset(seed=0)
    envs.action_space.seed(0)
    envs.step(envs.action_space.sample())  # the processes are warm
    start = time.perf_counter()
    for _ in range(steps):
        envs.step(envs.action_space.sample())  # episodes reset themselves (autoreset)
    elapsed = time.perf_counter() - start
    envs.close()
    return float(np.float64(steps * num_envs / elapsed))


def run_autonomy_bench(out: Callable[[str], None] = print) -> None:
    out("quadsim bench: camera images in code (quadsim.Cameras), front camera 320x240 @ 30 Hz, TinyRenderer")
    bare, sync = sync_cost_per_frame()
    out(
        f"  SYNC: per frame {sync * 1e3:.1f} ms added to stepping; bare getCameraImage {bare * 1e3:.1f} ms "
        f"(baseline): {sync / bare:.2f}x"
    )
    mean_ms, max_ms, read, dropped = pipelined_frame_age()
    out(
        f"  PIPELINED (2 render workers), paced to real time: newest frame {mean_ms:.0f} ms old on average, "
        f"{max_ms:.0f} ms at most ({read} reads, {dropped} captures dropped)"
    )
    try:
        import gymnasium  # noqa: F401
    except ImportError:
        out("  Gymnasium environments: skipped (pip install 'quadsim[gym]')")
        return
    out(f"  Gymnasium envs at 30 Hz, random actions            {'env steps/s':>12s} {'x real time':>12s}")
    for env_id, what in (("quadsim/Hover-v0", "state obs"), ("quadsim/TowerVision-v0", "64x64 image obs")):
        for num_envs in (1, 2):
            rate = env_steps_per_s(env_id, num_envs)
            how = "one env" if num_envs == 1 else "make_vec, 2 processes"
            out(f"  {what:16s} {how:22s}        {rate:12.0f} {rate / 30:11.1f}x")
    out("  (PyFlyt's and gym-pybullet-drones' envs, the issue's comparison, are not measured yet)")
