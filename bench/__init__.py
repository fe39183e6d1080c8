"""The test rig's benchmarks and scenario runner: programs that print JSON.

``python -m bench.link``, ``python -m bench.camera``, ``python -m bench.vehicle``,
``python -m bench.station_load`` and ``python -m bench.scenarios``. Not shipped: the
station never imports this package.
"""
