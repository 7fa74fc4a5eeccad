#!/usr/bin/env bash
# Installs what vplgi needs on a fresh Debian 12 machine, idempotently:
#   * libclang-dev (embree4-sys runs bindgen), mesa-vulkan-drivers + libvulkan1 (lavapipe, for the GPU backend)
#   * fonts-dejavu-core (the text of `vplgi sweep`'s PNG charts)
#   * chromium (headless: the test that loads `vplgi verify`'s HTML report in a real browser)
#   * the Embree 4.4 runtime, taken from the embreex wheel on PyPI (Debian 12 only packages Embree 3);
#   * for fuzzing: the nightly toolchain (rustup) and cargo-fuzz (cargo install), in ~/.cargo.
# The Embree libraries go to $VPLGI_EMBREE_DIR (default /usr/local/lib/vplgi-embree4) and are registered with
# ldconfig, so every binary, test and bench finds them without rpath tricks.
set -euo pipefail

EMBREE_DIR="${VPLGI_EMBREE_DIR:-/usr/local/lib/vplgi-embree4}"
EMBREE_WHEEL_VERSION="4.4.0.post1"
EMBREE_SONAME="libembree4-4aef3270.so.4"
TBB_SONAME="libtbb-dcf63f8c.so.12"

SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi

apt_packages=(libclang-dev mesa-vulkan-drivers libvulkan1 python3-pip unzip fonts-dejavu-core chromium)
missing=()
for p in "${apt_packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ "${#missing[@]}" -gt 0 ]; then
  echo "vplgi setup: installing apt packages: ${missing[*]}"
  # Another apt process may hold the dpkg lock: wait for it instead of failing.
  for attempt in 1 2 3 4 5 6 7 8 9 10; do
    if $SUDO apt-get update -qq && \
       DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq -o DPkg::Lock::Timeout=120 "${missing[@]}" >/dev/null; then
      break
    fi
    [ "$attempt" -eq 10 ] && { echo "vplgi setup: apt-get failed" >&2; exit 1; }
    echo "vplgi setup: apt busy or failed (attempt $attempt), retrying in 15 s"; sleep 15
  done
fi

if [ ! -f "$EMBREE_DIR/$EMBREE_SONAME" ] || [ ! -f "$EMBREE_DIR/$TBB_SONAME" ] || [ ! -L "$EMBREE_DIR/libembree4.so" ]; then
  echo "vplgi setup: fetching the Embree $EMBREE_WHEEL_VERSION runtime (embreex wheel from PyPI) into $EMBREE_DIR"
  tmp=$(mktemp -d)
  trap 'rm -rf "$tmp"' EXIT
  # Pinned platform and ABI tags, so the local Python version does not matter.
  python3 -m pip download --quiet --no-deps --only-binary=:all: --platform manylinux_2_28_x86_64 \
    --python-version 3.11 --implementation cp --abi cp311 "embreex==$EMBREE_WHEEL_VERSION" -d "$tmp"
  (cd "$tmp" && unzip -q -o ./*.whl "embreex.libs/*")
  $SUDO mkdir -p "$EMBREE_DIR"
  $SUDO install -m 0755 "$tmp/embreex.libs/$EMBREE_SONAME" "$tmp/embreex.libs/$TBB_SONAME" "$EMBREE_DIR/"
  # The linker looks for libembree4.so; the runtime finds the hashed SONAME through ldconfig.
  $SUDO ln -sf "$EMBREE_SONAME" "$EMBREE_DIR/libembree4.so"
fi

conf=/etc/ld.so.conf.d/vplgi-embree4.conf
if [ ! -f "$conf" ] || ! grep -qx "$EMBREE_DIR" "$conf"; then
  echo "$EMBREE_DIR" | $SUDO tee "$conf" >/dev/null
fi
if ! ldconfig -p | grep -q "$EMBREE_SONAME"; then
  $SUDO ldconfig
fi

# Fuzzing (make fuzz; 20 s of each target in make test): a nightly toolchain and cargo-fuzz,
# installed for this user only.
if ! rustup toolchain list 2>/dev/null | grep -q '^nightly'; then
  echo "vplgi setup: installing the nightly toolchain (cargo-fuzz needs it)"
  rustup toolchain install nightly --profile minimal
fi
if ! command -v cargo-fuzz >/dev/null 2>&1; then
  echo "vplgi setup: installing cargo-fuzz (a few minutes, once)"
  cargo install --locked --quiet cargo-fuzz --version 0.13.2
fi

echo "vplgi setup: ok (Embree 4 runtime in $EMBREE_DIR)"
