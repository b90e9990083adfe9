"""Plotting helpers (matplotlib figures, offscreen 3-D renders); the core never imports these."""
