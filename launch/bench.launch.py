"""The abb_ros bench with one command: ros2 launch abb_ros bench.launch.py [name:=value ...].

Starts, under the ROS namespace ``namespace``, the simulator (abb_simulator) and as chosen the
analysis (abb_analysis) and the example controller (abb_spin_controller). ``record`` makes the
simulator record the whole bench in process to ``record_dir``: its own topics as it publishes
them and the other nodes' topics from the middleware (a separate recorder reading the 1 kHz
topics would cost the simulator about 30 us per message and reader, docs/time_under_load.md).
Every node loads ``params_file`` (the drive's parameters; default the installed Table 1
file). When the simulator ends (a bad parameter, a failure), the whole launch ends with it.
Arguments: docs/ros_api.md.
Imports only launch and launch_ros, as the ROS 2 Jazzy launch documentation prescribes.
"""

from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, GroupAction, Shutdown
from launch.conditions import IfCondition
from launch.substitutions import LaunchConfiguration, PathJoinSubstitution
from launch_ros.actions import Node, PushRosNamespace
from launch_ros.parameter_descriptions import ParameterValue
from launch_ros.substitutions import FindPackageShare

ARGUMENTS = {
    'namespace': ('', 'ROS namespace of every bench node and topic (e.g. drive1)'),
    'params_file': (PathJoinSubstitution([FindPackageShare('abb_ros'), 'config',
                                          'cdrom_table1.yaml']),
                    'parameter file loaded by every node (drive.*; default Table 1)'),
    'real_time_factor': ('1.0', 'simulated seconds per wall second (1 = wall clock, 0 = as '
                         'fast as possible)'),
    'realtime_priority': ('0', "the simulator's SCHED_FIFO priority (0 = normal scheduler; "
                          'needs CAP_SYS_NICE or an rtprio limit)'),
    'analysis': ('true', 'run the stability analysis node (stability/margin)'),
    'controller': ('false', 'run the example controller spin_controller'),
    'record': ('false', "record every bench topic to record_dir, in the simulator's process"),
    'record_dir': ('', 'bag directory of the recording (default abb_bag_<date>-<time> in '
                   'the working directory); must not exist'),
    'live_view': ('false', "serve the simulator's topics to the Foxglove app on "
                  'ws://127.0.0.1:live_view_port (Foxglove WebSocket)'),
    'live_view_port': ('8765', 'port of the live view (0 = any free port, logged)'),
}
OTHER_NODES_TOPICS = ['stability/margin', '/diagnostics', 'spindle/speed_cmd',
                      'spindle/current_cmd']
"""The bench topics other nodes publish: the simulator's in-process recording (``record``, or
its service ~/start_recording) takes them into its bag too (record.topics), so that it holds
the bench."""
SHUTDOWN_S = '30'
"""Seconds a node gets to end after SIGINT before launch escalates to SIGTERM (launch's default,
5 s, is short for a loaded machine and for the simulator closing its bag)."""


def generate_launch_description():
    params_file = LaunchConfiguration('params_file')
    bench = GroupAction([
        PushRosNamespace(LaunchConfiguration('namespace')),
        Node(package='abb_ros', executable='simulator', name='abb_simulator',
             output='screen', sigterm_timeout=SHUTDOWN_S,
             on_exit=Shutdown(reason='the simulator ended'),
             parameters=[params_file, {
                 'real_time_factor': ParameterValue(LaunchConfiguration('real_time_factor'),
                                                    value_type=float),
                 'realtime_priority': ParameterValue(LaunchConfiguration('realtime_priority'),
                                                     value_type=int),
                 'live_view.enabled': ParameterValue(LaunchConfiguration('live_view'),
                                                     value_type=bool),
                 'live_view.port': ParameterValue(LaunchConfiguration('live_view_port'),
                                                  value_type=int),
                 'record.start': ParameterValue(LaunchConfiguration('record'),
                                                value_type=bool),
                 'record.path': ParameterValue(LaunchConfiguration('record_dir'),
                                               value_type=str),
                 'record.topics': OTHER_NODES_TOPICS}]),
        Node(package='abb_ros', executable='analysis', name='abb_analysis',
             output='screen', sigterm_timeout=SHUTDOWN_S, parameters=[params_file],
             condition=IfCondition(LaunchConfiguration('analysis'))),
        Node(package='abb_ros', executable='spin_controller', name='abb_spin_controller',
             output='screen', sigterm_timeout=SHUTDOWN_S, parameters=[params_file],
             condition=IfCondition(LaunchConfiguration('controller'))),
    ])
    return LaunchDescription(
        [DeclareLaunchArgument(name, default_value=default, description=text)
         for name, (default, text) in ARGUMENTS.items()] + [bench])
