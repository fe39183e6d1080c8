"""The HTTP and WebSocket API of the ground station (contract: see the dashboard's lib/)."""
