"""`bywire ros2`: the higher-level computer's bridge between ROS 2 and the robot's CAN bus (R-ROS2).

Everything that decides is pure and needs no ROS (settings, the speed loop, the bicycle model, age
gating, the stop ramp, enabling, odometry, diagnostics, the rosbag2 export); `link` owns the CAN
bus, in a process of its own (`link_process`); `node` is the thin rclpy shell, the only module
that imports rclpy.
"""
