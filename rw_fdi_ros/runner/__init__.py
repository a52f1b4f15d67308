"""The product path of one run: the graph as data (graph), its processes started and supervised (launcher,
shm), one scenario recorded as a bag (scenario_run), then read back as its summary (summary), its FDI
verdict (verdict) and its figure (residual_figure). ``rw-fdi run`` and launch/rw_fdi.launch.py import this
room; ``tools/`` may import it, never the reverse."""
