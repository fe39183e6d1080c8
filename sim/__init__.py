"""Stand-ins for the real parts (vehicle, cameras), so Visland runs without hardware.

Each stand-in speaks the real protocol over a real transport: the ArduCopter stand-in
(`sim.vehicle`) speaks MAVLink over TCP/UDP/serial, the CMUcam4 stand-in speaks
the camera's byte protocol on a pseudo-terminal.
"""
