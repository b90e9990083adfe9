#!/usr/bin/env bash
# Installs the Debian packages the project needs outside Python (idempotent):
# offscreen OpenGL for PyVista/VTK and MuJoCo, and Chromium for the browser test.
set -euo pipefail
pkgs=(libegl1 libegl-mesa0 libgl1-mesa-dri libosmesa6 libgl1 libxrender1 chromium fonts-dejavu-core)
missing=()
for p in "${pkgs[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then exit 0; fi
SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
echo "installing system packages: ${missing[*]}"
$SUDO apt-get -o DPkg::Lock::Timeout=600 update -qq
DEBIAN_FRONTEND=noninteractive $SUDO apt-get -o DPkg::Lock::Timeout=600 install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
