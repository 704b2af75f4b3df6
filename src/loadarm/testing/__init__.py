"""Test tooling, not for production use: the OPC UA load generator and the Playwright driver of the screen."""
