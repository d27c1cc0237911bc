"""ament_python package abb_ros (installed by colcon, or with pip into a virtual environment)."""
from glob import glob

from setuptools import find_packages, setup

package_name = 'abb_ros'

setup(
    name=package_name,
    version='0.1.0',
    packages=find_packages(exclude=['test', 'test.*', 'benchmarks']),
    data_files=[
        ('share/ament_index/resource_index/packages', ['resource/' + package_name]),
        ('share/' + package_name, ['package.xml']),
        ('share/' + package_name + '/config', glob('config/*.yaml')),
        ('share/' + package_name + '/config', glob('config/*.json')),
        ('share/' + package_name + '/config/scenarios', glob('config/scenarios/*.yaml')),
        ('share/' + package_name + '/launch', glob('launch/*.launch.py')),
        ('share/' + package_name + '/config/sweeps', glob('config/sweeps/*.yaml')),
        ('share/' + package_name + '/config/ros2_control', glob('config/ros2_control/*')),
    ],
    install_requires=['setuptools'],
    zip_safe=True,
    maintainer='abb_ros developers',
    maintainer_email='abb_ros@example.com',
    description='Simulated optical disk drive with an automatic ball balancer (ROS 2 Jazzy).',
    license='Apache-2.0',
    tests_require=['pytest'],
    entry_points={
        'console_scripts': [
            'simulator = abb_ros.nodes.ros.script:simulator',
            'analysis = abb_ros.nodes.ros.script:analysis',
            'recorder = abb_ros.nodes.ros.script:recorder',
            'abb-sim = abb_ros.cli:script',
            'spin_controller = abb_ros.nodes.ros.script:spin_controller',
            'warmup = abb_ros.model.warmup:main',
        ],
        'pytest11': ['abb_ros = abb_ros.testing.pytest_plugin'],
    },
)
