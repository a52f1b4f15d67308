"""Judging the FDI: the core-loop screen, bag evaluation, the thesis-scale study and its report."""
