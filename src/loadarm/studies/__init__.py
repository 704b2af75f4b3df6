"""Studies over many runs and sea states: campaigns over seeds and draws (``campaign``), metocean records
(``metocean``), the compiled monitor of one flange record (``kernel``), operability over years on Dask
(``operability``, its workers' start in ``_worker``), the Dask edge (``cluster``) and their figures (``plots``)."""
