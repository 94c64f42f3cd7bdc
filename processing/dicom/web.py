"""The study to a PACS over DICOMweb with dicomweb-client: STOW-RS of every instance, then QIDO-RS to check that
each one is there. Anything short of every instance found is a PacsFailed with what went wrong, in words.

Sending again is safe: every UID is derived from the record it came from (processing/dicom/identity.py), so the
PACS replaces or keeps what it has and never holds a second copy.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from pathlib import Path
from urllib.parse import urlsplit, urlunsplit

from processing.dicom.study import Study
from schemas.config import DicomConfig
from schemas.dicom import PacsOutcome
from schemas.errors import InvalidInput, PacsFailed

log = logging.getLogger(__name__)
SOP_INSTANCE_UID = "00080018"
FAILED_SOP_SEQUENCE = "00081198"
FAILURE_REASON = "00081197"


@dataclass(frozen=True)
class Endpoint:
    url: str
    username: str = ""
    password: str = ""
    token: str = ""
    ca_file: str = ""
    timeout_s: float = 60.0

    @property
    def shown(self) -> str:
        """The URL as recorded and shown: no credentials in it."""
        parts = urlsplit(self.url)
        host = parts.hostname or ""
        netloc = f"{host}:{parts.port}" if parts.port else host
        return urlunsplit((parts.scheme, netloc, parts.path, "", ""))


def _secret(path: str, what: str) -> str:
    try:
        return Path(path).read_text().strip()
    except OSError as exc:
        raise InvalidInput(f"[dicom] {what} {path} cannot be read: {exc.strerror}") from exc


def endpoint(config: DicomConfig, url: str = "") -> Endpoint:
    """The endpoint `url` (the command line's --to) or the configured one, with the configured credentials."""
    target = (url or config.endpoint).strip().rstrip("/")
    if not target:
        raise InvalidInput("no PACS is configured: set [dicom] endpoint (docs/dicom.md) or give --to URL")
    if urlsplit(target).scheme not in ("http", "https"):
        raise InvalidInput(f"the PACS address {target} is not an http:// or https:// DICOMweb root")
    password = _secret(config.password_file, "password_file") if config.password_file else ""
    token = _secret(config.token_file, "token_file") if config.token_file else ""
    return Endpoint(target, config.username, password, token, config.ca_file, config.timeout_s)


def _client(target: Endpoint):
    import requests
    from dicomweb_client.api import DICOMwebClient

    session = requests.Session()
    if target.token:
        session.headers["Authorization"] = f"Bearer {target.token}"
    elif target.username:
        session.auth = (target.username, target.password)
    if target.ca_file:
        session.verify = target.ca_file
    client = DICOMwebClient(url=target.url, session=session, timeout=target.timeout_s)
    client.set_http_retry_params(retry=False)
    return client


def _partial(target: Endpoint, failed: int, sent: int, reasons: list[str]) -> PacsFailed:
    why = f" (failure reason {', '.join(sorted(set(reasons)))})" if reasons else ""
    return PacsFailed(
        f"the PACS at {target.shown} stored only part of the study: {failed} of {sent} objects refused{why}; "
        "nothing was marked as sent, and sending again stores each object once"
    )


def _refused_objects(response) -> tuple[int, list[str]] | None:
    """The objects a STOW-RS answer lists as failed (its FailedSOPSequence, DICOM JSON), with their failure
    reasons; None when the answer holds no such list."""
    try:
        body = response.json()
    except ValueError:
        return None
    items = body.get(FAILED_SOP_SEQUENCE, {}).get("Value", []) if isinstance(body, dict) else []
    if not items:
        return None
    reasons = [str(v) for item in items for v in item.get(FAILURE_REASON, {}).get("Value", [])]
    return len(items), reasons


def _said(response) -> str:
    """What an error answer says, short: its JSON "Message" (Orthanc's way) or the start of its text."""
    try:
        body = response.json()
    except ValueError:
        body = None
    if isinstance(body, dict) and isinstance(body.get("Message"), str):
        return body["Message"][:200]
    return " ".join(response.text.split())[:200]


def _failure(target: Endpoint, exc: Exception, doing: str, sent: int = 0) -> PacsFailed:
    import requests

    if isinstance(exc, requests.HTTPError) and exc.response is not None:
        status = exc.response.status_code
        refused = _refused_objects(exc.response) if sent else None
        if refused is not None:  # a STOW-RS answer of 409 (or 4xx) that lists the objects it refused
            return _partial(target, refused[0], sent, refused[1])
        said = _said(exc.response)
        if status in (401, 403):
            why = f"refused the credentials ({status}): check [dicom] username, password_file or token_file"
        elif 400 <= status < 500:
            why = f"refused the request ({status}{': ' + said if said else ''})"
        else:
            why = f"failed ({status}{': ' + said if said else ''})"
        return PacsFailed(f"while {doing}, the PACS at {target.shown} {why}; nothing was marked as sent")
    if isinstance(exc, requests.Timeout):
        return PacsFailed(
            f"the PACS at {target.shown} did not answer within {target.timeout_s:g} s while {doing}; nothing was "
            "marked as sent: send again when it is reachable"
        )
    if isinstance(exc, requests.ConnectionError):
        return PacsFailed(
            f"the PACS at {target.shown} cannot be reached while {doing} (is it running, is the address right, is "
            "the network up?); nothing was marked as sent: send again when it is reachable"
        )
    return PacsFailed(f"the PACS at {target.shown} gave an answer burnedge cannot read while {doing}: {exc}")


def stored_instances(target: Endpoint, study_uid: str) -> set[str]:
    """The SOP Instance UIDs the PACS holds in the study (QIDO-RS)."""
    import requests

    client = _client(target)
    try:
        found = client.search_for_instances(study_instance_uid=study_uid, fields=["SOPInstanceUID"])
    except (requests.RequestException, ValueError) as exc:
        raise _failure(target, exc, "asking what the study holds") from exc
    return {item[SOP_INSTANCE_UID]["Value"][0] for item in found if item.get(SOP_INSTANCE_UID, {}).get("Value")}


def send(study: Study, target: Endpoint) -> PacsOutcome:
    """STOW-RS every instance of the study, then QIDO-RS that each is there."""
    import requests

    expected = {str(ds.SOPInstanceUID) for ds in study.instances}
    before = stored_instances(target, study.study_uid)
    client = _client(target)
    try:
        answer = client.store_instances(study.instances, study_instance_uid=study.study_uid)
    except (requests.RequestException, ValueError) as exc:
        raise _failure(target, exc, "storing the study", sent=len(expected)) from exc
    failed = list(getattr(answer, "FailedSOPSequence", []))
    if failed:  # a 202: stored with warnings, some refused
        reasons = [str(item.FailureReason) for item in failed if "FailureReason" in item]
        raise _partial(target, len(failed), len(expected), reasons)
    missing = expected - stored_instances(target, study.study_uid)
    if missing:
        raise PacsFailed(
            f"the PACS at {target.shown} accepted the study, but {len(missing)} of {len(expected)} objects are not "
            "there when asked (QIDO-RS); nothing was marked as sent"
        )
    log.info("study %s stored at %s: %d objects", study.study_uid, target.shown, len(expected))
    return PacsOutcome(
        endpoint=target.shown, study_uid=study.study_uid, instances=len(expected), already_there=len(before & expected)
    )
