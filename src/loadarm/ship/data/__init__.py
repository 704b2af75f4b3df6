"""Hydrodynamic coefficients shipped for the example berths (NetCDF, named by their key)."""
