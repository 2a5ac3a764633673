#!/usr/bin/env bash
# Installs the peers into bench/.venv-sysid from PyPI. SIPPY's PyPI name is `sippy-unipi`
# (`sippy` on PyPI is an unrelated SIP stack); pysib is `pysib`.
set -euo pipefail
cd "$(dirname "$0")/../.."
[ -x bench/.venv-sysid/bin/python ] || python3 -m venv bench/.venv-sysid
bench/.venv-sysid/bin/pip install -q numpy scipy sippy-unipi pysib
