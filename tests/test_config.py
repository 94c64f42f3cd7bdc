"""Configuration: one typed object, every field documented, overrides in a fixed order."""

from __future__ import annotations

import pytest

from harness.processes import REPO
from schemas.config import load_config
from schemas.config_docs import field_docs, render, sections
from schemas.errors import InvalidInput


def test_every_config_field_has_a_docstring():
    for cls in ("Config", *sections()):
        for name, _, doc in field_docs()[cls]:
            assert doc, f"{cls}.{name} needs a docstring"


def test_configuration_doc_is_current():
    assert (REPO / "docs" / "configuration.md").read_text() == render(), (
        "run: python -m schemas.config_docs > docs/configuration.md"
    )


def test_file_then_environment(tmp_path):
    f = tmp_path / "c.toml"
    f.write_text('[gateway]\nport = 9000\nhost = "0.0.0.0"\n[clinical]\nchild_max_age_years = 15\n')
    cfg = load_config(f, environ={"BURNEDGE_GATEWAY_PORT": "9100"})
    assert (cfg.gateway.port, cfg.gateway.host, cfg.clinical.child_max_age_years) == (9100, "0.0.0.0", 15.0)


@pytest.mark.parametrize(
    "text",
    [
        "[gateway]\nport = 0\n",
        "[gateway]\nportt = 1\n",
        "[gateway\n",
        "[security]\nargon2_memory_kib = 8\nargon2_parallelism = 4\n",
    ],
)
def test_bad_config_is_refused_with_a_reason(tmp_path, text):
    f = tmp_path / "c.toml"
    f.write_text(text)
    with pytest.raises(InvalidInput):
        load_config(f, environ={})


def test_the_example_config_is_valid():
    assert load_config(REPO / "deploy" / "burnedge.example.toml", environ={}).gateway.host == "0.0.0.0"


def test_list_settings_come_comma_separated_from_the_environment():
    cfg = load_config(None, environ={"BURNEDGE_SECURITY_PAIRED_DEVICE_ROLES": "clinician, nurse"})
    assert cfg.security.paired_device_roles == ["clinician", "nurse"]
    with pytest.raises(InvalidInput):
        load_config(None, environ={"BURNEDGE_SECURITY_PAIRED_DEVICE_ROLES": "janitor"})


def test_a_phone_app_folder_without_the_app_is_refused_with_what_to_do(tmp_path):
    with pytest.raises(InvalidInput, match="has no index.html and sw.js: point it at a copy of gateway/phones/app"):
        load_config(None, environ={"BURNEDGE_GATEWAY_PHONE_APP_DIR": str(tmp_path)})
    for name in ("index.html", "sw.js"):
        (tmp_path / name).write_text("")
    assert load_config(None, environ={"BURNEDGE_GATEWAY_PHONE_APP_DIR": str(tmp_path)}).gateway.phone_app_dir
