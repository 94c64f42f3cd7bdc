"""COLMAP's own feature database, read-only: the pictures, their raw matches and the verified image pairs.

This is the one module that reads a database burnedge does not own; its tables are COLMAP's (images, matches,
two_view_geometries), and a pair of images is stored as one pair_id.
"""

from __future__ import annotations

import sqlite3
from dataclasses import dataclass
from pathlib import Path

PAIR_ID_BASE = 2147483647
"""COLMAP packs the image pair (i, j), i < j, into one pair_id as i * 2147483647 + j."""


@dataclass(frozen=True)
class MatchTables:
    """What COLMAP's feature database says about the pictures and how they matched."""

    names: dict[int, str]
    """Picture file name by COLMAP image_id."""
    matches: dict[tuple[int, int], int]
    """Raw feature matches per image pair."""
    verified: dict[tuple[int, int], tuple[int, int]]
    """Per geometrically verified pair: (inlier matches, COLMAP's TwoViewGeometry configuration)."""


def read_match_tables(database: Path) -> MatchTables:
    """The images, matches and two-view geometries of the COLMAP database at `database`, opened read-only."""
    with sqlite3.connect(f"file:{database}?mode=ro", uri=True) as connection:
        names = dict(connection.execute("SELECT image_id, name FROM images"))
        matches = {image_pair(pid): rows for pid, rows in connection.execute("SELECT pair_id, rows FROM matches")}
        verified = {
            image_pair(pid): (rows, config)
            for pid, rows, config in connection.execute("SELECT pair_id, rows, config FROM two_view_geometries")
        }
    connection.close()
    return MatchTables(names=names, matches=matches, verified=verified)


def image_pair(pair_id: int) -> tuple[int, int]:
    """The two image_ids a COLMAP pair_id stands for."""
    second = pair_id % PAIR_ID_BASE
    return (pair_id - second) // PAIR_ID_BASE, second
