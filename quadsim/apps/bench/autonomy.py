"""`bench --section autonomy`: what code that reads the cameras pays, in both camera modes.

- SYNC: the cost per frame added to stepping, against the bare getCameraImage call of the same
  camera measured in the same run (the baseline);
- PIPELINED: how old the newest frame is when code reads it, with the simulation paced to real
  time (as a live robot program would be), in ms of simulation time;
- the Gymnasium environments (with the `gym` extra): env steps per second at the 30 Hz agent
  rate, one env and gymnasium.make_vec over two processes, random actions; Hover-v0's vector env
  in one process (make_vec's default) of 1, 16 and 64 envs against one env flying the same
  episodes, under random actions, a climb from the floor, and the same climb in flight;
- beside them, the peers' hover envs (PyFlyt's QuadX-Hover, gym-pybullet-drones' HoverAviary)
  timed by the same loop in their own processes, where they are installed (quadsim.apps.bench.peers).
"""

from __future__ import annotations

import subprocess
import time
from collections.abc import Callable

from quadsim.apps.bench.figures import best_seconds
from quadsim.apps.bench.peers import (
    PEERS,
    PeerResult,
    SteppingTimes,
    measure_peer,
    not_installed_line,
    peer_python,
    step_randomly,
)
from quadsim.core.invocation import install_extra
from quadsim.core.types import Twist, ZMode
from quadsim.physics.pybullet_quiet import pb
from quadsim.sensors.camera import CameraSpec
from quadsim.sensors.rendering import projection_matrix, view_matrix
from quadsim.session.pacing import RealTimePacer
from quadsim.sim.cameras import CameraMode, Cameras
from quadsim.sim.config import SimConfig
from quadsim.sim.simulator import Simulator

FRONT = CameraSpec("front", "front_camera_link", 320, 240, rate_hz=30)


def _hovering(z_mode: ZMode = ZMode.HEIGHT) -> Simulator:
    sim = Simulator(SimConfig(z_mode=z_mode))
    sim.send(Twist())  # hold 2.0 m
    sim.run_for(3.0)
    return sim


def sync_cost_per_frame(frames: int = 60, repeats: int = 3) -> tuple[float, float]:
    """(bare getCameraImage s/frame, SYNC cameras' added s/frame) for the front camera at 320x240."""
    from quadsim.sensors.camera import camera_pose

    with _hovering() as sim:
        steps = frames * (sim.config.rates.physics_hz // FRONT.rate_hz)
        state = sim.state
        pose = camera_pose(sim.vehicle.camera_mount(FRONT.link_name), state.position_m, state.orientation_xyzw)
        view, proj, cid = view_matrix(pose), projection_matrix(FRONT), sim.scene_client.posed()

        def bare() -> None:
            for _ in range(frames):
                pb.getCameraImage(320, 240, view, proj, renderer=pb.ER_TINY_RENDERER, physicsClientId=cid)

        stepping = best_seconds(lambda: sim.step(steps), repeats)
        baseline = best_seconds(bare, repeats)
        with Cameras(sim, (FRONT,)):
            with_cameras = best_seconds(lambda: sim.step(steps), repeats)
    return baseline / frames, (with_cameras - stepping) / frames


def pipelined_frame_age(wall_s: float = 5.0, workers: int = 2) -> tuple[float, float, int, int]:
    """Paced to real time, the front camera read every camera period: (mean age ms, max age ms,
    frames read, captures dropped)."""
    with _hovering() as sim, Cameras(sim, (FRONT,), CameraMode.PIPELINED, render_workers=workers) as cams:
        cams.wait()
        period = sim.config.rates.physics_hz // FRONT.rate_hz
        ages: list[int] = []
        pacer = RealTimePacer(sim.config.rates.physics_hz, max_frame_s=None)  # paced as a live bridge is
        pacer.rebase(sim.step_count)
        start = time.perf_counter()
        while time.perf_counter() - start < wall_s:
            sim.step(period)
            pacer.wait(sim.step_count)
            age = cams.frame_age_steps("front")
            if age is not None:
                ages.append(age)
        to_ms = 1e3 / sim.config.rates.physics_hz
        return sum(ages) / len(ages) * to_ms, max(ages) * to_ms, len(ages), cams.frames_dropped


def env_stepping(env_id: str, steps: int = 300) -> SteppingTimes:
    """One env, timed by the loop the peers are timed by (random actions, resets when episodes end)."""
    import gymnasium as gym

    import quadsim.envs  # noqa: F401 - registers the environments

    env = gym.make(env_id)
    times = step_randomly(env, steps)
    env.close()
    return times


def env_steps_per_s(env_id: str, num_envs: int, steps: int = 300) -> float:
    """Env steps per second (summed over the envs), random actions, after one reset."""
    import gymnasium as gym
    import numpy as np

    import quadsim.envs  # noqa: F401 - registers the environments

    if num_envs == 1:
        return env_stepping(env_id, steps).steps_per_s
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


#: the vector env sizes the bench measures
VECTOR_SIZES = (1, 16, 64)
#: the policies the vector env is measured under: what the vehicles do, the agent steps flown
#: before the timing starts, and how each env's action is drawn (None: at random in [-1, 1])
VECTOR_POLICIES: dict[str, tuple[str, int, tuple[float, float, float, float] | None]] = {
    "random": ("random actions from the start: on and near the floor (PyBullet's)", 0, None),
    "take-off": ("a slow climb from the start: the take-off (PyBullet's), then clear", 0, (0.1, 0.0, 0.3, 0.1)),
    "in flight": ("the same climb from 2 s on: in flight, clear of everything", 60, (0.1, 0.0, 0.3, 0.1)),
}


def vector_rates(steps: int = 150) -> dict[tuple[str, int, str], float]:
    """Hover-v0's env steps per second (summed over the envs) for the vector env in one process
    (make_vec's default: quadsim.envs.vector) of each of VECTOR_SIZES ("vector"), and for one env
    (gymnasium.make) flying the same episodes one after the other ("one"): env i reset with seed
    i and given env i's actions. Under each of VECTOR_POLICIES; each episode's own resets
    included."""
    import gymnasium as gym
    import numpy as np

    import quadsim.envs  # noqa: F401 - registers the environments

    rates: dict[tuple[str, int, str], float] = {}
    warm = gym.make("quadsim/Hover-v0")  # the flight core loaded and made for an env's arguments
    warm.reset(seed=0)
    for _ in range(60):
        warm.step(np.array([0.1, 0.0, 0.3, 0.1], np.float32))
    warm.close()
    for policy, (_, before, held) in VECTOR_POLICIES.items():
        rng = np.random.default_rng(0)
        largest = max(VECTOR_SIZES)
        actions = (
            rng.uniform(-1, 1, (before + steps, largest, 4))
            if held is None
            else np.broadcast_to(np.array(held), (before + steps, largest, 4))
        ).astype(np.float32)
        for num_envs in VECTOR_SIZES:
            envs = gym.make_vec("quadsim/Hover-v0", num_envs=num_envs)
            envs.reset(seed=0)
            for action in actions[:before, :num_envs]:
                envs.step(action)
            start = time.perf_counter()
            for action in actions[before:, :num_envs]:
                envs.step(action)
            rates[policy, num_envs, "vector"] = steps * num_envs / (time.perf_counter() - start)
            envs.close()
            one, elapsed = gym.make("quadsim/Hover-v0"), 0.0
            for i in range(num_envs):  # the same episodes, one after the other
                one.reset(seed=i)
                for action in actions[:before, i]:
                    one.step(action)
                start = time.perf_counter()
                for action in actions[before:, i]:
                    if any(one.step(action)[2:4]):
                        one.reset()
                elapsed += time.perf_counter() - start
            rates[policy, num_envs, "one"] = steps * num_envs / elapsed
            one.close()
    return rates


def vector_lines() -> list[str]:
    """The vector env's rates against one env's flying the same episodes, measured in the same
    run, and issue 33's target."""
    rates = vector_rates()
    lines = [
        f"  Hover-v0 in one process, env steps/s    {'vector env':>11s} {'one env, same episodes':>23s} {'ratio':>7s}"
    ]
    ratio = {(p, n): rates[p, n, "vector"] / rates[p, n, "one"] for p in VECTOR_POLICIES for n in VECTOR_SIZES}
    for policy, (what, _, _) in VECTOR_POLICIES.items():
        lines.append(f"  {policy}: {what}")
        for num_envs in VECTOR_SIZES:
            vector, one = rates[policy, num_envs, "vector"], rates[policy, num_envs, "one"]
            lines.append(
                f"    {num_envs:2d} env{'s' * (num_envs != 1)} (make_vec; make){'':16s}"
                f"{vector:11.0f} {one:23.0f} {ratio[policy, num_envs]:6.2f}x"
            )
    lines.append(
        f"  target: a vector env of 16 >= 5x one env's steps/s in flight "
        f"[{'met' if ratio['in flight', 16] >= 5 else 'MISSED'}: {ratio['in flight', 16]:.2f}x in flight, "
        f"{ratio['take-off', 16]:.2f}x with the take-off, {ratio['random', 16]:.2f}x random: on the floor PyBullet steps each]"
    )
    return lines


def peer_lines(quadsim_hover: SteppingTimes, agent_hz: int = 30) -> list[str]:
    """The peers' hover envs at `agent_hz` (and at their own default rate where it differs), each
    against quadsim's Hover-v0 measured in this run, or why a peer is not measured."""
    lines = [
        f"  peers' hover envs, one env each in its own process, same loop  {'env steps/s':>12s} "
        f"{'x real time':>12s} {'w/o resets':>11s} {'quadsim is':>11s} {'w/o resets':>11s}"
    ]
    for peer in PEERS:
        python = peer_python(peer)
        if python is None:
            lines.append("  " + not_installed_line(peer))
            continue
        rates = (agent_hz,) if peer.default_agent_hz == agent_hz else (agent_hz, peer.default_agent_hz)
        for hz in rates:
            try:
                found = measure_peer(peer, python, hz)
            except (RuntimeError, OSError, subprocess.TimeoutExpired) as error:
                lines.append(f"  {peer.name}: not measured: {error}")
                break
            lines.append(_peer_line(found, quadsim_hover, agent_hz))
    lines.append(
        f"  (quadsim/Hover-v0 here: {quadsim_hover.steps_per_s:.0f} env steps/s, "
        f"{quadsim_hover.stepping_steps_per_s:.0f} w/o its {quadsim_hover.resets} resets; all physics at 240 Hz; "
        "'quadsim is' compares sim-seconds per wall-second)"
    )
    return lines


def _peer_line(found: PeerResult, quadsim_hover: SteppingTimes, agent_hz: int) -> str:
    what = f"{found.peer.name} {found.version} {found.peer.env_name} @ {found.agent_hz} Hz"
    if found.agent_hz == found.peer.default_agent_hz:
        what += " (its default)"
    # sim-seconds per wall-second, so that a peer at another agent rate compares honestly
    ratio = (quadsim_hover.steps_per_s / agent_hz) / found.sim_s_per_wall_s
    stepping_ratio = (quadsim_hover.stepping_steps_per_s / agent_hz) / (found.stepping_steps_per_s / found.agent_hz)
    return (
        f"  {what:62s} {found.steps_per_s:12.0f} {found.sim_s_per_wall_s:11.1f}x "
        f"{found.stepping_steps_per_s:11.0f} {ratio:10.2f}x {stepping_ratio:10.2f}x  ({found.resets} resets)"
    )


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
        out(f"  Gymnasium environments: skipped ({install_extra('gym')})")
        return
    out(f"  Gymnasium envs at 30 Hz, random actions            {'env steps/s':>12s} {'x real time':>12s}")
    hover = env_stepping("quadsim/Hover-v0")
    for env_id, what in (("quadsim/Hover-v0", "state obs"), ("quadsim/TowerVision-v0", "64x64 image obs")):
        for num_envs in (1, 2):
            rate = (
                hover.steps_per_s
                if env_id == "quadsim/Hover-v0" and num_envs == 1
                else env_steps_per_s(env_id, num_envs)
            )
            how = "one env" if num_envs == 1 else "make_vec, 2 processes"
            out(f"  {what:16s} {how:22s}        {rate:12.0f} {rate / 30:11.1f}x")
    for line in vector_lines():
        out(line)
    for line in peer_lines(hover):
        out(line)
