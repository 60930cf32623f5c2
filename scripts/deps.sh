#!/usr/bin/env bash
# Installs the Debian packages isin's build, tests and examples need, if any are missing.
# Usage: scripts/deps.sh [extra packages…]   (uses sudo when not run as root)
set -euo pipefail
packages=(g++ clang libclang-rt-14-dev cmake make pkg-config doctest-dev libstb-dev libtinyobjloader-dev "$@")
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
[ ${#missing[@]} -eq 0 ] && exit 0
echo "isin: installing Debian packages: ${missing[*]}" >&2
sudo=""
[ "$(id -u)" -eq 0 ] || sudo="sudo"
export DEBIAN_FRONTEND=noninteractive
$sudo apt-get update -qq
$sudo apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
