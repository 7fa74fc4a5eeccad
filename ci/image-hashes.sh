#!/usr/bin/env bash
# Renders the built-in Cornell box in every cluster and fuzzy mode on both backends (small sizes,
# about a minute with lavapipe) and prints the SHA-256 of each image.exr. Run it with the binary
# before and after a refactor that must not change images, and diff the two lists:
#   ci/image-hashes.sh target/release/vplgi /tmp/before > before.txt   (on the old commit)
#   ci/image-hashes.sh target/release/vplgi /tmp/after  > after.txt    (on the new one)
#   diff before.txt after.txt
set -euo pipefail
bin=${1:?usage: ci/image-hashes.sh VPLGI_BINARY OUT_DIR}
out=${2:?usage: ci/image-hashes.sh VPLGI_BINARY OUT_DIR}
mkdir -p "$out"
export XDG_RUNTIME_DIR="${XDG_RUNTIME_DIR:-$(mktemp -d)}"
common=(--width 96 --height 80 --vpls 2000 --k-sp 600 --k-vpl 200)
modes=("none weighted 1" "vpl weighted 1" "sp hard 1" "sp average 1" "sp weighted 1" "both hard 1" "both average 1" "both weighted 1" "both weighted 2" "none weighted 2")
for backend in cpu gpu; do
  for m in "${modes[@]}"; do
    read -r cluster fuzzy spp <<<"$m"
    name="$backend-$cluster-$fuzzy-spp$spp"
    "$bin" render "${common[@]}" --backend "$backend" --cluster "$cluster" --fuzzy "$fuzzy" --spp "$spp" --out "$out/$name" >"$out/$name.log" 2>&1 \
      || { echo "render failed: $name (see $out/$name.log)" >&2; exit 1; }
    printf '%s  %s\n' "$(sha256sum "$out/$name/image.exr" | cut -d' ' -f1)" "$name"
  done
done
