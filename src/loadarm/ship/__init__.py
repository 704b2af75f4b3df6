"""The moored ship (issue 12): hull geometry so far; hydrodynamics, moorings and motion to come."""
