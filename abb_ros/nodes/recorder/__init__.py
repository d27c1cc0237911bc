"""The recorder node (``ros2 run abb_ros recorder``) and the bag recording it shares."""
