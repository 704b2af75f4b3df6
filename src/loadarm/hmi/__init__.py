"""The operator's web screen (issue 15): served by ``loadarm serve --hmi``; FastAPI and a WebSocket; ISA-101
style, ISA-18.2 alarm list."""
