"""Latency of the planning node: ``/slideplan/plan`` from the request to the response over DDS.

The node ``slideplan ros serve --scene square`` runs in its own process pinned to one core; this
process publishes, on the other, a depth cloud of the demo scene (the crescent on the square table,
rendered by the MuJoCo robot's camera with its noise, a new noise draw per cloud, 5 Hz) and the arm's
joint state, and calls the service: first until it answers (the cold node), then ``--calls`` times
(the warm node: the table plane known from the first cloud). Each answer's own timings (perceive,
plan) are read from its JSON. Every call must solve. Then ``--executes`` calls of ``/slideplan/execute``
(the node perceives and plans, opens the hand through ``/gripper/set``, which this process serves at
once, and publishes the reach): from the request to the first ``JointTrajectory`` on
``/joint_trajectory_controller/joint_trajectory``. The joint state here never moves, so each execution
then stops, refused, once the reach's time is up; only the first message's latency is kept.

Prints and writes (docs/benchmarks/ros.md) median / p95 with the build, CPU and date named. Not a test:
``make bench``.

    python benchmarks/ros_bench.py [--calls 30] [--executes 10]
"""

from __future__ import annotations

import argparse
import itertools
import json
import os
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np

from plan_bench import write_report  # benchmarks/ is the script's directory, hence on sys.path


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--calls", type=int, default=30, help="warm calls")
    parser.add_argument("--executes", type=int, default=10, help="warm /slideplan/execute calls, to the first trajectory message")
    parser.add_argument("--out", type=Path, default=Path("docs/benchmarks/ros.md"))
    args = parser.parse_args()
    os.environ.setdefault("MUJOCO_GL", "egl")
    domain = str(os.getpid() % 100 + 100)
    os.environ.update(ROS_DOMAIN_ID=domain, ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")

    import rclpy
    from sensor_msgs.msg import JointState, PointCloud2
    from std_msgs.msg import Header
    from std_srvs.srv import SetBool, Trigger
    from trajectory_msgs.msg import JointTrajectory

    from slideplan.sim.closed_loop import default_camera
    from slideplan.ros.messages import cloud_message
    from slideplan.ros.sim import Sim, camera_pose_of
    from slideplan.world.scenes import load_scene

    scene = load_scene("square")
    sim = Sim(scene, "crescent", (0.55, -0.08, 0.4))
    sim.step_to(0.05)
    clouds = [sim.optical_points(sim.depth()) for _ in range(5)]  # five noise draws, cycled
    home, _ = sim.joint_state()
    sim.close()
    cores = sorted(os.sched_getaffinity(0))
    node_core, client_cores = cores[-1], set(cores[:-1]) or {cores[-1]}
    node = subprocess.Popen(
        [sys.executable, "-m", "slideplan.cli", "ros", "serve", "--scene", "square",
         "--camera-pose", *(f"{value:.9g}" for value in camera_pose_of(default_camera(scene)))],
        stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, preexec_fn=lambda: os.sched_setaffinity(0, {node_core}))
    os.sched_setaffinity(0, client_cores)
    rclpy.init()
    client_node = rclpy.create_node("slideplan_bench")
    cloud_pub = client_node.create_publisher(PointCloud2, "/camera/points", 5)
    joint_pub = client_node.create_publisher(JointState, "/joint_states", 10)
    stop = threading.Event()

    def sensors() -> None:
        for points in itertools.cycle(clouds):
            if stop.is_set():
                return
            cloud_pub.publish(cloud_message(points, Header(frame_id="slideplan_camera")))
            joint_pub.publish(JointState(name=sim.joint_names, position=home.tolist(), velocity=[0.0] * len(home)))
            stop.wait(0.2)

    threading.Thread(target=sensors, daemon=True).start()
    service = client_node.create_client(Trigger, "/slideplan/plan")
    execute = client_node.create_client(Trigger, "/slideplan/execute")
    arrivals: list[float] = []
    client_node.create_subscription(JointTrajectory, "/joint_trajectory_controller/joint_trajectory",
                                    lambda message: arrivals.append(time.perf_counter()), 10)

    def gripper(request, response):
        response.success = True
        return response

    client_node.create_service(SetBool, "/gripper/set", gripper)

    def first_message() -> float:
        """An execution from its request to its first trajectory message (s); it is then left to fail."""
        arrivals.clear()
        started = time.perf_counter()
        future = execute.call_async(Trigger.Request())
        while not arrivals and time.perf_counter() - started < 60.0:
            rclpy.spin_once(client_node, timeout_sec=0.01)
        rclpy.spin_until_future_complete(client_node, future, timeout_sec=60.0)
        if not arrivals:
            raise SystemExit(f"no trajectory message within 60 s: {future.result().message if future.done() else 'no answer'}")
        return arrivals[0] - started

    def call() -> tuple[float, dict]:
        started = time.perf_counter()
        future = service.call_async(Trigger.Request())
        rclpy.spin_until_future_complete(client_node, future, timeout_sec=60.0)
        return time.perf_counter() - started, json.loads(future.result().message)

    try:
        assert service.wait_for_service(timeout_sec=60.0), "the node never served /slideplan/plan"
        started = time.perf_counter()
        while True:
            cold_s, answer = call()
            if answer["status"] == "solved":
                break
            if time.perf_counter() - started > 60.0:
                raise SystemExit(f"the node does not plan: {answer}")
            time.sleep(0.2)
        warm = [call() for _ in range(args.calls)]
        after_plan = first_message()  # the node executes the plan of the last /slideplan/plan
        executes = [first_message() for _ in range(args.executes)]  # each plans on the call
    finally:
        stop.set()
        node.terminate()
        node.wait(timeout=20)
        client_node.destroy_node()
        rclpy.shutdown()
    unsolved = [answer for _, answer in warm if answer["status"] != "solved"]
    if unsolved:
        raise SystemExit(f"{len(unsolved)} of {args.calls} calls did not solve: {unsolved[0]}")
    columns = {"request to response": [seconds for seconds, _ in warm],
               "perceive (in the node)": [answer["perceive_s"] for _, answer in warm],
               "plan (in the node)": [answer["planning_time_s"] for _, answer in warm],
               "/slideplan/execute request to the first trajectory message (perceive, plan, open the hand, reach)": executes}
    lines = ["# Planning node latency", "",
             "The node pinned to one core, the client on the other. "
             f"`python benchmarks/ros_bench.py --calls {args.calls}`: `/slideplan/plan` (std_srvs/Trigger over "
             "Fast DDS, localhost) on the demo scene's rendered 320 x 240 depth cloud; the warm node knows the "
             "table plane from its first cloud.", "",
             f"The first call of a fresh node (cold): {cold_s:.3f} s. `/slideplan/execute` right after a "
             f"`/slideplan/plan` (it executes that plan): {1000 * after_plan:.0f} ms to the first trajectory message.", "",
             "| warm node, per call | median | p95 |", "|---|---|---|"]
    for name, values in columns.items():
        lines.append(f"| {name} | {1000 * np.median(values):.0f} ms | {1000 * np.percentile(values, 95):.0f} ms |")
    write_report(lines, args.out)


if __name__ == "__main__":
    main()
