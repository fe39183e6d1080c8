"""The data directory keeps to its owner: folders 0700, files 0600.

The station's process creates everything with umask 077 (SQLite's database and
journals, the flights' frames and tlogs, the references' pictures, the token), and a
data directory left from an older start is tightened: the folder itself 0700 (then
nothing under it can be reached by others), its own files 0600 and folders 0700.
"""

from __future__ import annotations

import os
import stat
from pathlib import Path

DIR_MODE = 0o700
FILE_MODE = 0o600


def prepare_data_dir(path: str | Path) -> Path:
    """Create (or tighten) the data directory; sets this process's umask to 077."""
    os.umask(0o077)
    folder = Path(path)
    folder.mkdir(mode=DIR_MODE, parents=True, exist_ok=True)
    os.chmod(folder, DIR_MODE)
    for entry in folder.iterdir():
        try:
            mode = entry.lstat().st_mode
            if stat.S_ISDIR(mode):
                os.chmod(entry, DIR_MODE)
            elif stat.S_ISREG(mode):
                os.chmod(entry, FILE_MODE)
        except OSError:
            continue  # vanished meanwhile, or not ours: the folder's 0700 still guards it
    return folder
