"""ArduCopter stand-in: a simulated quadrotor that speaks real MAVLink like ArduPilot SITL.

In-process use::

    from sim.vehicle import SimConfig, SimVehicle, VehicleServer

    server = VehicleServer(SimVehicle(SimConfig(seed=1)), "tcp:127.0.0.1:5760")
    server.start()  # returns once it listens; server.address says where
    ...
    server.stop()

Command line: ``python -m sim.vehicle --mavlink tcp:127.0.0.1:5760``.
"""

from sim.vehicle.autopilot import MODE_NAMES, Estimate, SimVehicle, VehicleTruth
from sim.vehicle.config import SimConfig
from sim.vehicle.mavlink_server import VehicleServer
from sim.vehicle.params import ParamInfo, ParamStore
from sim.vehicle.precland import LandingTargetMsg

__all__ = [
    "MODE_NAMES",
    "Estimate",
    "LandingTargetMsg",
    "ParamInfo",
    "ParamStore",
    "SimConfig",
    "SimVehicle",
    "VehicleServer",
    "VehicleTruth",
]
