#!/usr/bin/env bash
# Renders one vplgi reference on a Slurm cluster: an array job with one task per row tile
# (`vplgi reference --tile I/N`), then a merge job that starts when every tile has succeeded
# (`--dependency=afterok`) and joins them with `vplgi merge`, bit-identically to a single run.
#
# Usage: ci/slurm/submit-reference.sh TILES OUT_DIR [SCENE] [vplgi reference options...]
#   e.g. ci/slurm/submit-reference.sh 16 /shared/refs/conference scenes/conference.glb --seeds 64 --width 1024 --height 720
#
# OUT_DIR must be on a file system every node sees; the tiles go to OUT_DIR/tiles/I and the joined
# reference to OUT_DIR/merged. Environment:
#   VPLGI         the vplgi binary, as every node sees it (default: vplgi on PATH)
#   SBATCH_ARGS   extra sbatch options for both jobs, e.g. "--partition=render --time=02:00:00"
#   TILE_CPUS     cores per tile task (default 2; vplgi uses them all through rayon)
# Prints the two job ids. `squeue -u $USER` shows them; each task's log is OUT_DIR/logs/.
set -euo pipefail
if [ $# -lt 2 ]; then
  sed -n '2,16p' "$0" | sed 's/^# \{0,1\}//' >&2
  exit 2
fi
tiles=$1 out=$2
shift 2
case "$tiles" in ''|*[!0-9]*|0) echo "submit-reference.sh: TILES must be a positive integer, got '$tiles'" >&2; exit 2;; esac
here=$(cd "$(dirname "$0")" && pwd)
vplgi=${VPLGI:-vplgi}
mkdir -p "$out/tiles" "$out/logs"
out=$(cd "$out" && pwd)
# shellcheck disable=SC2086 # SBATCH_ARGS is a list of options
array=$(sbatch --parsable ${SBATCH_ARGS:-} --job-name=vplgi-tiles --array="1-$tiles" --cpus-per-task="${TILE_CPUS:-2}" \
  --output="$out/logs/tile-%a.log" "$here/reference-tile.sbatch" "$vplgi" "$tiles" "$out" "$@")
# shellcheck disable=SC2086
merge=$(sbatch --parsable ${SBATCH_ARGS:-} --job-name=vplgi-merge --dependency="afterok:$array" --kill-on-invalid-dep=yes \
  --output="$out/logs/merge.log" "$here/reference-merge.sbatch" "$vplgi" "$tiles" "$out")
echo "tiles: job $array (array 1-$tiles), merge: job $merge (after every tile succeeds); reference: $out/merged"
