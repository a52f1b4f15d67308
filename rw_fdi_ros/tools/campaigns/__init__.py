"""Recording runs: one run, its summary, campaigns, bag replay through the FDI graph."""
