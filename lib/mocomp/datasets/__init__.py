"""Named example motions (synthetic, embedded) and real clips from the data directory."""
from .config import ENV_VAR, data_dir

__all__ = ["data_dir", "ENV_VAR"]
