"""The segmentation model the analyses use: its version, how it runs, and its held-out Dice by skin tone."""

from __future__ import annotations

import functools
from pathlib import Path

from litestar import Controller, get

from base.web.problems import SESSION, problems
from base.web.site import AuthedRequest
from gateway.dependencies import ServicesDep
from processing.segmentation.card import model_info
from processing.segmentation.infer import SHIPPED_MODEL
from schemas.segmentation import ModelInfo


@functools.lru_cache(maxsize=4)
def _card(path: str, modified_ns: int) -> ModelInfo:
    return model_info(path)  # read once per file version: loading the model takes a few hundred ms


def current_model(configured: str) -> ModelInfo:
    path = Path(configured) if configured else SHIPPED_MODEL
    return _card(str(path), path.stat().st_mtime_ns if path.exists() else 0)


class ModelController(Controller):
    path = "/api/v1/segmentation-model"
    tags = ["analyses"]

    @get(
        "/",
        sync_to_thread=True,
        summary="The burn segmentation model: version, hash, how it runs, held-out Dice by skin tone",
        responses=problems(*SESSION, 422),
    )
    def read(self, request: AuthedRequest, services: ServicesDep) -> ModelInfo:
        return current_model(services.config.analysis.model)
