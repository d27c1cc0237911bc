"""The live view: a Foxglove WebSocket server, its connections, its protocol."""
