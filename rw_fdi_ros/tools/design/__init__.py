"""Designing the FDI from runs: samples, training the Elman networks, fitting threshold curves, the shipped defaults."""
