"""The baseline: a bare Litestar endpoint under the same server settings as the gateway."""

from __future__ import annotations

import sys

import uvicorn
from litestar import Litestar, get


@get("/bare", sync_to_thread=False)
def bare() -> dict:
    return {"status": "ok"}


if __name__ == "__main__":
    uvicorn.run(Litestar([bare]), host="127.0.0.1", port=int(sys.argv[1]), log_level="warning", access_log=False)
