#!/usr/bin/env bash
# Where batch-1 planning time goes, for every planner the docs compare, side by side in one run (one machine
# state: each report records the matmul rate it ran at).
#
# Regenerates: `results/benchmarks/plan_profile.md`, `results/benchmarks/plan_profile_block_reach.md`, `results/benchmarks/plan_profile_onnx.md`, `results/benchmarks/plan_profile_realtime.md`, `results/benchmarks/plan_profile_realtime_warm6.md`, `results/benchmarks/plan_profile_student.md`
#
#   bash benchmarks/plan_profiles.sh      # about 6 compute-minutes on 2 cores; alone on the machine
#
# The trained sampler (torch, both tasks; ONNX Runtime), the real-time default (DDPM-8 warm from step 4), round 3's
# candidate (warm from step 6) and the few-step student (scdp_student: DDIM-2, 2 calls per chunk; its own sampler
# under every profile, ONNX Runtime at batch 1 as for the default), on Navigation's committed cpu checkpoints
# unless named.
set -euo pipefail
RUN=${RUN:-results/cpu}
OUT=results/benchmarks
profile() { python benchmarks/plan_profile.py --checkpoints "$RUN/$1/checkpoints" --task "$1" --method "$2" "${@:3}"; }
profile navigation scdp --scenes 10 --profile trained --out "$OUT/plan_profile"
profile block_reach scdp --scenes 10 --profile trained --out "$OUT/plan_profile_block_reach"
profile navigation scdp --scenes 10 --profile trained --runtime onnx --out "$OUT/plan_profile_onnx"
profile navigation scdp --scenes 20 --profile realtime --out "$OUT/plan_profile_realtime"
profile navigation scdp --scenes 20 --profile realtime --warm-skip 6 --out "$OUT/plan_profile_realtime_warm6"
profile navigation scdp_student --scenes 20 --profile realtime --runtime auto --out "$OUT/plan_profile_student"
