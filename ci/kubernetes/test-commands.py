#!/usr/bin/env python3
"""Part of `make test-slurm`: checks the Kubernetes manifests without a cluster (none is reachable
from the machines vplgi is tested on). It checks their structure (Indexed Job, completions =
parallelism = TILES, the same volume and image in both Jobs) and then runs each pod's own shell
command locally, with the environment Kubernetes would give it (JOB_COMPLETION_INDEX 0..TILES-1,
then the merge), and checks the merged reference is bit-identical to one `vplgi reference`.
What it cannot check is Kubernetes itself: scheduling, the volume, retries.

Usage: ci/kubernetes/test-commands.py VPLGI_BINARY WORK_DIR
"""
import filecmp
import os
import shutil
import subprocess
import sys

import yaml

here = os.path.dirname(os.path.abspath(__file__))


def fail(msg):
    sys.exit(f"test-k8s: {msg}")


def job(name):
    with open(os.path.join(here, name)) as f:
        doc = yaml.safe_load(f)
    if doc.get("kind") != "Job" or doc.get("apiVersion") != "batch/v1":
        fail(f"{name}: expected a batch/v1 Job")
    pod = doc["spec"]["template"]["spec"]
    if pod.get("restartPolicy") not in ("Never", "OnFailure"):
        fail(f"{name}: a Job's pods need restartPolicy Never or OnFailure")
    (container,) = pod["containers"]
    env = {e["name"]: e["value"] for e in container.get("env", [])}
    return doc, pod, container, env


def run_pod(container, env, extra):
    cmd = container["command"] + container["args"]
    full = dict(os.environ, **env, **extra)
    r = subprocess.run(cmd, env=full, capture_output=True, text=True)
    if r.returncode != 0:
        fail(f"pod command {extra} failed ({r.returncode}): {r.stderr.strip()}")


def main():
    vplgi, work = os.path.abspath(sys.argv[1]), os.path.abspath(sys.argv[2])
    tiles_doc, tiles_pod, tiles_c, tiles_env = job("reference-tiles.yaml")
    _, merge_pod, merge_c, merge_env = job("reference-merge.yaml")
    spec = tiles_doc["spec"]
    if spec.get("completionMode") != "Indexed":
        fail("reference-tiles.yaml: completionMode must be Indexed (each pod takes tile JOB_COMPLETION_INDEX + 1)")
    n = int(tiles_env["TILES"])
    if not (spec["completions"] == spec["parallelism"] == n == int(merge_env["TILES"])):
        fail("completions, parallelism and both Jobs' TILES must be the same number")
    if tiles_env["OUT"] != merge_env["OUT"] or tiles_c["image"] != merge_c["image"]:
        fail("the two Jobs must share OUT and the image")
    claims = [p["volumes"][0]["persistentVolumeClaim"]["claimName"] for p in (tiles_pod, merge_pod)]
    if claims[0] != claims[1]:
        fail(f"the two Jobs mount different claims {claims}")

    # The pods' commands, run here with a small reference of 3 tiles.
    shutil.rmtree(work, ignore_errors=True)
    os.makedirs(work)
    small = {
        "PATH": os.path.dirname(vplgi) + os.pathsep + os.environ["PATH"],
        "TILES": "3",
        "SCENE": "cornell-box",
        "REFERENCE_ARGS": "--width 40 --height 30 --vpls 300 --seeds 3",
        "OUT": os.path.join(work, "k8s"),
    }
    for index in range(3):
        run_pod(tiles_c, {**tiles_env, **small}, {"JOB_COMPLETION_INDEX": str(index)})
    run_pod(merge_c, {**merge_env, **small}, {})
    single = os.path.join(work, "single")
    subprocess.run([vplgi, "reference", "cornell-box", *small["REFERENCE_ARGS"].split(), "--out", single], check=True, capture_output=True)
    for f in ("mean.exr", "variance.exr"):
        if not filecmp.cmp(os.path.join(small["OUT"], "merged", f), os.path.join(single, f), shallow=False):
            fail(f"{f} of the pods' merged reference differs from the single run's")
    print("test-k8s: passed: the manifests are Indexed Jobs that agree on TILES, OUT, image and volume, and their pods' "
          "commands (3 tiles, then the merge) gave a reference bit-identical to one run (no cluster: Kubernetes itself is not exercised)")


main()
