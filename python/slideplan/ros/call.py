"""``slideplan ros call``: call a std_srvs/Trigger service of the planning node and print its answer.

The ``ros`` extra installs rclpy as wheels, without ROS 2's ``ros2`` command line tools; this is the
one call those tools would make (``ros2 service call /slideplan/plan std_srvs/srv/Trigger``).
"""

from __future__ import annotations

import rclpy
from rclpy.executors import SingleThreadedExecutor
from std_srvs.srv import Trigger

from ..errors import InputError


def call_trigger(service: str, *, wait_s: float, answer_s: float, ros_args: list[str]) -> tuple[bool, str]:
    """Call ``service`` once and return its answer.

    Args:
        service: the service's full name, e.g. ``/slideplan/plan``.
        wait_s: how long to wait for the service to appear (s).
        answer_s: how long to wait for its answer once called (s).
        ros_args: what follows ``--ros-args`` on the command line (remappings, parameters).

    Returns:
        ``(success, message)`` of the Trigger response.

    Raises:
        InputError: the service did not appear within ``wait_s`` (field ``service``) or did not answer within
            ``answer_s`` (field ``timeout``).
    """
    context = rclpy.Context()
    rclpy.init(args=["slideplan_call", *ros_args], context=context)
    node = rclpy.create_node("slideplan_call", context=context)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    try:
        client = node.create_client(Trigger, service)
        if not client.wait_for_service(timeout_sec=wait_s):
            raise InputError(f"{service} did not appear within {wait_s:g} s (is `slideplan ros serve` running, with the same "
                             "ROS_DOMAIN_ID and ROS_AUTOMATIC_DISCOVERY_RANGE?)", field="service")
        future = client.call_async(Trigger.Request())
        executor.spin_until_future_complete(future, timeout_sec=answer_s)
        if not future.done():
            raise InputError(f"{service} did not answer within {answer_s:g} s", field="timeout")
        response = future.result()
        return bool(response.success), response.message
    finally:
        executor.shutdown()
        node.destroy_node()
        rclpy.shutdown(context=context)
