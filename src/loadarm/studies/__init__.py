"""Studies over many sea states: metocean records, the batched operability kernel, its distribution on Dask."""
