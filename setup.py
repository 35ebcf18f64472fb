from glob import glob
import os

from setuptools import find_packages, setup

package_name = 'gps_error_ros'

setup(
    name=package_name,
    version='0.1.0',
    packages=find_packages(exclude=['test']),
    # py.typed: the package's annotations are for its users' type checkers too (PEP 561)
    package_data={package_name: ['py.typed'], f'{package_name}.ns3': ['gps_error_ns3.hpp']},
    data_files=[
        ('share/ament_index/resource_index/packages',
            ['resource/' + package_name]),
        ('share/' + package_name, ['package.xml']),
        (os.path.join('share', package_name, 'config', 'profiles'),
            sorted(glob('config/profiles/*.yaml'))),
        (os.path.join('share', package_name, 'config'), sorted(glob('config/*.yaml'))),
        (os.path.join('share', package_name, 'config', 'zones'),
            sorted(glob('config/zones/*.geojson'))),
    ],
    # The core and the `gps_error` command need no ROS: rclpy and the message
    # packages come from the ROS install (or requirements-ros.txt).
    install_requires=['setuptools', 'numpy', 'scipy', 'pyproj', 'PyYAML',
                      'matplotlib', 'rosbags'],
    # gps_error import: recordings in (NMEA, GPX); an extra, not a core need.
    # gps_error_sumo: SUMO live (the eclipse-sumo wheel, TraCI); an extra too.
    # Zone maps (node parameter zones, simulate --zones): shapely 2.
    # ns3: the mobility source and the P2V study inside ns-3 (ns-3's Python bindings).
    # fast: the diagnosis's jump and regime filters compiled (numba); numpy without it.
    extras_require={'docs': ['mkdocs', 'mkdocs-material', 'mkdocstrings-python'],
                    'fast': ['numba'],
                    'import': ['pynmea2', 'gpxpy'],
                    'ns3': ['ns3'],
                    'parquet': ['pyarrow'],
                    'dask': ['pyarrow', 'dask', 'distributed'],
                    'smoother': ['gtsam'],
                    'sumo': ['eclipse-sumo', 'traci', 'sumolib'],
                    'zones': ['shapely>=2']},
    zip_safe=True,
    maintainer='gps_error_ros maintainers',
    maintainer_email='maintainers@gps-error-ros.invalid',
    description='Smartphone GPS errors (AR(3), Rostami et al.) for ROS 2 simulation',
    license='Apache-2.0',
    tests_require=['pytest'],
    entry_points={
        'console_scripts': [
            'gps_error_node = gps_error_ros.ros.error_node:main',
            'gps_error_demo = gps_error_ros.ros.demo:main',
            'gps_error = gps_error_ros.cli:main',
            'gps_calibration_node = gps_error_ros.ros.calibration_node:main',
            'gps_error_play = gps_error_ros.ros.bag_play:main',
            'gps_error_record = gps_error_ros.ros.bag_record:main',
            'gps_error_sumo = gps_error_ros.ros.sumo_bridge:main',
        ],
    },
)
