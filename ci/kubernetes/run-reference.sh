#!/usr/bin/env bash
# Renders a vplgi reference on Kubernetes: applies the tiles' Indexed Job, waits until every tile
# has completed, then applies the merge Job and waits for it. Edit the two manifests first (image,
# TILES, SCENE, REFERENCE_ARGS, volume). Usage: ci/kubernetes/run-reference.sh [kubectl options...]
#   TIMEOUT   how long to wait for the tiles (default 24h)
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
kubectl "$@" apply -f "$here/reference-tiles.yaml"
if ! kubectl "$@" wait --for=condition=complete --timeout="${TIMEOUT:-24h}" job/vplgi-reference-tiles; then
  echo "run-reference.sh: the tiles' Job did not complete; see kubectl logs -l app=vplgi-reference" >&2
  exit 1
fi
kubectl "$@" apply -f "$here/reference-merge.yaml"
kubectl "$@" wait --for=condition=complete --timeout=1h job/vplgi-reference-merge
echo "run-reference.sh: the merged reference is in OUT/merged on the volume"
