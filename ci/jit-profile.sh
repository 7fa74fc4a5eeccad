#!/usr/bin/env bash
# Where lavapipe spends a kernel's time, instruction by instruction.
#
# Debian's Mesa is a release build: llvmpipe's own dumps (GALLIVM_DEBUG=asm, LP_DEBUG) are
# compiled out, and `perf` sees the JIT-compiled shaders only as anonymous addresses. So this
# runs COMMAND, waits DELAY seconds (until the kernel of interest runs: read the stage times of a
# first `vplgi render --backend gpu --profile`), then, with gdb, samples the program counters of
# all threads SAMPLES times, dumping each new anonymous executable mapping (the JIT code). It
# prints how many samples fell in JIT code, the hottest code region by 256-byte windows, and
# writes that region's disassembly annotated with sample counts to OUT.annotated.txt.
#
#   ci/jit-profile.sh [--delay S] [--samples N] [--out PREFIX] -- COMMAND...
#   ci/jit-profile.sh --delay 2.9 -- target/release/vplgi render --backend gpu --width 512 --height 512
#
# Needs gdb and objdump (apt install gdb binutils) and permission to ptrace the child (root, or
# kernel.yama.ptrace_scope = 0). Each sample stops the process for a moment: the timings of a
# profiled run are not measurements.
set -euo pipefail

delay=2
samples=30
out=/tmp/jit-profile
while [ $# -gt 0 ]; do
  case $1 in
    --delay) delay=$2; shift 2 ;;
    --samples) samples=$2; shift 2 ;;
    --out) out=$2; shift 2 ;;
    --) shift; break ;;
    -h|--help) sed -n '2,19p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    *) echo "jit-profile: unknown option $1 (see --help)" >&2; exit 2 ;;
  esac
done
[ $# -gt 0 ] || { echo "jit-profile: no command given (see --help)" >&2; exit 2; }
for tool in gdb objdump python3; do
  command -v $tool >/dev/null || { echo "jit-profile: needs $tool (apt install gdb binutils python3)" >&2; exit 2; }
done

rm -f "$out".*
"$@" >"$out.stdout" 2>&1 &
pid=$!
sleep "$delay"
kill -0 $pid 2>/dev/null || { echo "jit-profile: the command ended within $delay s; see $out.stdout" >&2; exit 1; }

# One gdb attach per sample: the program counter of every thread, and a dump of every anonymous
# executable mapping (JIT code) not dumped yet (kernels may be compiled while the command runs).
cat >"$out.gdb.py" <<'PY'
import gdb, os
out = os.environ["JIT_PROFILE_OUT"]
with open(out + ".pcs", "a") as pcs:
    for t in gdb.selected_inferior().threads():
        t.switch()
        pcs.write(hex(gdb.selected_frame().pc()) + "\n")
for line in gdb.execute("info proc mappings", to_string=True).splitlines():
    f = line.split()
    # start end size offset perms, and no file name: anonymous and executable, JIT code.
    if len(f) == 5 and f[4] == "r-xp" and int(f[1], 16) - int(f[0], 16) <= (1 << 22):
        path = f"{out}.{f[0]}.bin"
        if not os.path.exists(path):
            gdb.execute(f"dump binary memory {path} {f[0]} {f[1]}")
PY
: >"$out.pcs"
for _ in $(seq 1 "$samples"); do
  kill -0 $pid 2>/dev/null || break
  JIT_PROFILE_OUT=$out gdb -p $pid -batch -x "$out.gdb.py" >/dev/null 2>&1 || true
done
wait $pid || true

python3 - "$out" <<'PY'
import collections, glob, os, re, subprocess, sys
out = sys.argv[1]
pcs = collections.Counter(int(x, 16) for x in open(out + ".pcs").read().split() if x.startswith("0x"))
regions = []
for f in glob.glob(out + ".0x*.bin"):
    start = int(re.search(r"\.(0x[0-9a-f]+)\.bin$", f).group(1), 16)
    end = start + os.path.getsize(f)
    regions.append((sum(n for pc, n in pcs.items() if start <= pc < end), start, end, f))
total = sum(pcs.values())
in_jit = sum(r[0] for r in regions)
print(f"{total} thread samples, {in_jit} in JIT code ({100 * in_jit / max(total, 1):.0f} %; the rest are mostly idle threads)")
if not regions or in_jit == 0:
    sys.exit("jit-profile: no sample in JIT code: is the kernel running after --delay?")
n, start, end, f = max(regions)
print(f"hottest region {start:#x}-{end:#x}: {n} samples")
windows = collections.Counter()
for pc, k in pcs.items():
    if start <= pc < end:
        windows[(pc - start) // 256] += k
for w, k in sorted(windows.items()):
    print(f"  +{w * 256:#07x}  {'#' * k} {k}")
asm = subprocess.run(["objdump", "-D", "-b", "binary", "-mi386:x86-64", f"--adjust-vma={start:#x}", f], capture_output=True, text=True).stdout
with open(out + ".annotated.txt", "w") as a:
    for line in asm.splitlines():
        m = re.match(r"\s*([0-9a-f]+):\s+(?:[0-9a-f]{2} )+\s*(.*)", line)
        if m and m.group(2):
            pc = int(m.group(1), 16)
            a.write(f"{pcs.get(pc, 0):4d}  +{pc - start:#07x}  {m.group(2)}\n")
print(f"annotated disassembly: {out}.annotated.txt (sample count, offset, instruction)")
PY
