#!/usr/bin/env bash
# Prepares this checkout on a fresh Debian machine: the system libraries the native
# wheels load (open3d needs libusb, EGL/GL and X11 client libraries), a virtual
# environment in .venv, and the project with its test tools. Safe to run again.
# --test also installs Debian's chromium, the headless browser the page tests drive (Playwright), and its
# postgresql, the server the burn center's PostgreSQL tests start in a temporary folder (harness/postgres.py), and
# orthanc with orthanc-dicomweb, the PACS the DICOM tests start on loopback with their own configuration
# (harness/orthanc.py; the system service Debian sets up is not used by them), and dicom3tools, whose dciodvfy
# and dcentvfy check every DICOM object the export writes against the standard's rules (tests/test_dicom_mesh.py).
set -euo pipefail
cd "$(dirname "$0")/.."

PYTHON=${PYTHON:-python3}
SYSTEM_PACKAGES=(libusb-1.0-0 libgl1 libegl1 libx11-6 libudev1 libgomp1 poppler-utils)
case "${1:-}" in
    --test) SYSTEM_PACKAGES+=(chromium postgresql libnss3-tools orthanc orthanc-dicomweb dicom3tools) ;;
    "") ;;
    *)
        echo "bootstrap: unknown argument $1 (the only one is --test)" >&2
        exit 2
        ;;
esac

missing=()
command -v "$PYTHON" >/dev/null 2>&1 || missing+=(python3)
if command -v "$PYTHON" >/dev/null 2>&1 && ! "$PYTHON" -c 'import venv, ensurepip' >/dev/null 2>&1; then
    missing+=(python3-venv)
fi
for pkg in "${SYSTEM_PACKAGES[@]}"; do
    dpkg-query -W -f='${Status}' "$pkg" 2>/dev/null | grep -q "install ok installed" || missing+=("$pkg")
done
if ((${#missing[@]})); then
    if [ "$(id -u)" -ne 0 ]; then
        echo "bootstrap: these Debian packages are missing: ${missing[*]}; run as root or install them first" >&2
        exit 1
    fi
    echo "bootstrap: installing ${missing[*]}" >&2
    apt-get update -qq
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi

"$PYTHON" - <<'PY'
import sys
if sys.version_info < (3, 11):
    raise SystemExit(f"bootstrap: burnedge needs Python 3.11 or newer, found {sys.version.split()[0]}")
PY

[ -x .venv/bin/python ] || "$PYTHON" -m venv .venv
.venv/bin/python -m pip install --quiet --disable-pip-version-check -e ".[test]"
echo "bootstrap: ready (.venv)" >&2
