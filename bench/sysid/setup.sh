#!/usr/bin/env bash
# Installs the peers into bench/.venv-sysid from PyPI. SIPPY's PyPI name is `sippy-unipi`
# (`sippy` on PyPI is an unrelated SIP stack); pysib is `pysib`. Pinned to the versions
# bj_peers.json records (SIPPY's casadi and control as RESULTS.md records them).
set -euo pipefail
cd "$(dirname "$0")/../.."
[ -x bench/.venv-sysid/bin/python ] || python3 -m venv bench/.venv-sysid
bench/.venv-sysid/bin/pip install -q numpy==2.4.6 scipy==1.17.1 sippy-unipi==1.0.1 casadi==3.8.2 control==0.10.2 pysib==0.2.5
