"""GET /api/v1/segmentation-model: the model's version, passes and fairness table, as the gateway serves them."""

from __future__ import annotations

import msgspec
from litestar.testing import TestClient

from gateway.app import create_app
from harness.processes import login
from processing.segmentation.infer import SHIPPED_MODEL, BurnSegmenter
from schemas.accounts import Role
from schemas.config import AnalysisConfig
from schemas.segmentation import ModelInfo, TrainingReport
from tests.conftest import make_user


def test_the_gateway_serves_the_models_version_and_fairness_table(client, auth):
    r = client.get("/api/v1/segmentation-model", headers=auth["nurse"])
    assert r.status_code == 200, r.text
    info = msgspec.json.decode(r.content, type=ModelInfo)
    segmenter = BurnSegmenter(SHIPPED_MODEL)
    report = msgspec.json.decode((SHIPPED_MODEL.parent / "training_report.json").read_bytes(), type=TrainingReport)
    assert info.version == segmenter.metadata["version"] == report.model_version
    assert info.sha256 == report.model_sha256 and info.passes == report.passes
    assert info.fairness == report.fairness and info.real_validation == report.real_validation
    assert info.architecture == segmenter.metadata["architecture"] and "EfficientNet-Lite0" in info.architecture
    assert client.get("/api/v1/segmentation-model").status_code == 401


def test_a_missing_model_file_is_a_clear_error_not_a_crash(config, tmp_path):
    broken = msgspec.structs.replace(config, analysis=AnalysisConfig(model=str(tmp_path / "gone.onnx")))
    app = create_app(broken)
    with TestClient(app) as c:
        make_user(app.state.services, "nurse", Role.nurse)
        r = c.get("/api/v1/segmentation-model", headers=login(c, "nurse"))
        assert r.status_code == 422 and "gone.onnx" in r.json()["detail"], r.text
        assert c.get("/health").status_code == 200  # the gateway keeps serving
