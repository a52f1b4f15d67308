"""ament_python package: `ros2 run rw_fdi_ros <exe>` finds the console scripts in lib/rw_fdi_ros."""
import os
from glob import glob

from setuptools import find_packages, setup

PACKAGE = "rw_fdi_ros"
# graph/entry.py: the same
NODES = ["plant", "pid_controller", "recorder", "elman_observer", "linear_observer", "model_observer", "isolation",
         "wheel_allocation", "player", "composed", "momentum_dumping", "live_view", "plugin_observer",
         "wheel_telemetry"]



def config_files():
    """Everything under config/ (scenarios, the DDS profile, the shipped FDI models and thresholds of
    both methods) into share/rw_fdi_ros/config, folder by folder: the nodes read them there on an install."""
    out = []
    for folder, _, files in sorted(os.walk("config")):
        if files:
            out.append((f"share/{PACKAGE}/{folder}", sorted(os.path.join(folder, f) for f in files)))
    return out


setup(
    name=PACKAGE,
    version="0.1.0",
    packages=find_packages(exclude=["test"]),
    package_data={"rw_fdi_ros.tools.evaluation": ["report_schema.json"]},
    data_files=[
        ("share/ament_index/resource_index/packages", [f"resource/{PACKAGE}"]),
        (f"share/{PACKAGE}", ["package.xml"]),
        (f"share/{PACKAGE}/launch", glob("launch/*.py")),
    ] + config_files(),
    # what the nodes and every `rw-fdi` command import (the ROS 2 packages come from the ROS install, or the
    # ros-kilted-* wheels of requirements.txt); the groups below are for what only some work needs
    install_requires=["setuptools", "numpy", "scipy", "pyyaml", "rosbags", "mcap", "mcap-ros2-support", "sgp4",
                      "ppigrf", "matplotlib", "tqdm", "jsonschema"],
    extras_require={
        "train": ["torch==2.13.0"],              # rw-fdi train, reproduce: the Elman observers' training
        "cluster": ["dask", "distributed"],      # --scheduler: campaigns, evaluate and reproduce on a Dask cluster
        "live": ["foxglove-sdk", "websockets"],  # rw-fdi run --live, launch live:=PORT: the run in Foxglove
        "parquet": ["pyarrow"],                  # rw-fdi telemetry on a Parquet table (CSV needs nothing)
        "test": ["pytest", "hypothesis", "websockets"],   # `colcon test` runs pytest; websockets: a Foxglove client
    },
    zip_safe=True,
    maintainer="rw_fdi_ros developers",
    maintainer_email="dev@rw-fdi.local",
    description="Reaction-wheel FDI as a ROS 2 node graph",
    license="Apache-2.0",
    entry_points={
        "console_scripts": [f"{n} = {PACKAGE}.graph.entry:{n}" for n in NODES]
        + ["rw-fdi = rw_fdi_ros.cli:main"],
    },
)
