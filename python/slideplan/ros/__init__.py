"""slideplan on a ROS 2 robot (the ``ros`` extra; docs/ros2.md): the planning node ``slideplan``
(:mod:`slideplan.ros.serve`) and the MuJoCo robot ``slideplan_sim`` (:mod:`slideplan.ros.sim`). rclpy and
the message packages are imported here only."""
