"""Reproducing the papers' figures and tables in one run (``mocomp reproduce``).

Every notebook in ``notebooks/`` ends by writing its paper-vs-ours rows with
:func:`mocomp.reproduce.results.write_results`; the report reads them.
"""
from .results import ResultRow, read_results, write_results

__all__ = ["ResultRow", "read_results", "write_results"]
