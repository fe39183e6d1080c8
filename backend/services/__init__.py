"""The station's services, one job each; the API routes depend on these, never on storage.

- :mod:`.events`: the event log (stored, kept in memory for new viewers, fanned out);
- :mod:`.runtime`: the settings the operator may change while running;
- :mod:`.references`: reference pictures of the pad, the active one, their verifiers;
- :mod:`.flights`: recorded flights and their files;
- :mod:`.vehicle`: commands to the vehicle and its telemetry;
- :mod:`.status`: the status and telemetry snapshots, refreshed off the event loop.
"""
