#!/usr/bin/env bash
# The test command: installs what the tests need, then checks formatting and lints and runs
# the whole test suite (unit, integration, CLI, and the GPU tests on Vulkan/lavapipe).
#
# GPU tests need a Vulkan driver. With CI=true a missing adapter fails those tests; without
# it they are skipped loudly. Tests that need ../shared/assets run where it exists (below). Run as root on Debian to have the driver installed here.
set -euo pipefail
cd "$(dirname "$0")/.."

need_apt=()
if ! ldconfig -p 2>/dev/null | grep -q 'libvulkan.so.1'; then need_apt+=(libvulkan1); fi
if ! ls /usr/share/vulkan/icd.d/lvp_icd*.json >/dev/null 2>&1; then need_apt+=(mesa-vulkan-drivers); fi
# nv-flip (the FLIP metric of `pathlight compare`) compiles its C++ core with the cc crate.
if ! command -v c++ >/dev/null; then need_apt+=(g++); fi
# The viewer test opens a window on a virtual X server.
if ! command -v xvfb-run >/dev/null; then need_apt+=(xvfb); fi
if [ ${#need_apt[@]} -gt 0 ]; then
    if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null; then
        echo "ci/test.sh: installing ${need_apt[*]}"
        apt-get update -qq
        DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "${need_apt[@]}" >/dev/null
    else
        echo "ci/test.sh: WARNING: ${need_apt[*]} missing and cannot be installed (not root/apt); GPU tests will skip or fail" >&2
    fi
fi

if ! command -v cargo >/dev/null; then
    echo "ci/test.sh: cargo not found; install Rust from https://rustup.rs" >&2
    exit 1
fi

# Mesa prints a harmless warning without it.
export XDG_RUNTIME_DIR="${XDG_RUNTIME_DIR:-/tmp}"

# The tests that read ../shared/assets run with the `shared-assets` feature; without the
# folder they are reported as ignored. CI always has it: there a missing folder is an error.
features=()
if [ -d ../shared/assets ]; then
    features+=(shared-assets)
elif [ "${CI:-}" = true ]; then
    echo "ci/test.sh: CI=true but ../shared/assets is missing; the asset tests cannot run" >&2
    exit 1
else
    echo "ci/test.sh: ../shared/assets not found; the tests that need it will be reported as ignored" >&2
fi

# Intel Open Image Denoise for the `oidn` feature (`--denoiser oidn`): Debian 12 does not
# package it; PyPI's pyoidn wheel ships libOpenImageDenoise.so, which the oidn crate links
# through OIDN_DIR and the tests load through LD_LIBRARY_PATH.
oidn_dir() {
    python3 -c 'import os, pyoidn; print(os.path.join(os.path.dirname(pyoidn.__file__), "oidn"))' 2>/dev/null
}
if ! oidn_dir >/dev/null && command -v python3 >/dev/null; then
    echo "ci/test.sh: installing pyoidn (Open Image Denoise) for the oidn feature"
    python3 -m pip install -q "pyoidn==2.5.1.0" || true
fi
if dir=$(oidn_dir) && [ -f "$dir/lib/libOpenImageDenoise.so" ]; then
    export OIDN_DIR="$dir"
    export LD_LIBRARY_PATH="$dir/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}"
    features+=(oidn)
elif [ "${CI:-}" = true ]; then
    echo "ci/test.sh: CI=true but Open Image Denoise could not be installed (pip install pyoidn); the oidn feature cannot be tested" >&2
    exit 1
else
    echo "ci/test.sh: SKIPPED the oidn feature: no Open Image Denoise (pip install pyoidn)" >&2
fi
feature_args=()
if [ ${#features[@]} -gt 0 ]; then
    feature_args=(--features "$(IFS=,; echo "${features[*]}")")
fi

cargo fmt --check
cargo clippy --release --all-targets "${feature_args[@]}" -- -D warnings
# cargo-nextest runs each test in its own process, all test files' tests in one pool. Under
# `cargo test` the GPU tests of one file share one device and its one queue, so two test
# threads' lavapipe dispatches took turns: with an empty shader cache tests/gpu took 1,017 s
# under `cargo test` and 554 s under nextest on this project's 2-core CI machine
# (bench/history/lavapipe.md). nextest does not run doctests; `cargo test --doc` does.
if cargo nextest --version >/dev/null 2>&1; then
    cargo nextest run --release --no-fail-fast "${feature_args[@]}"
    cargo test --release --doc "${feature_args[@]}"
else
    echo "ci/test.sh: cargo-nextest not found (cargo install cargo-nextest); running cargo test, whose GPU tests take about twice as long" >&2
    cargo test --release "${feature_args[@]}"
fi

# The farm driver (farm/pathlight_farm.py) on a local Dask cluster, a worker killed
# mid-shard. It needs Python 3 with dask.distributed, installed here when missing.
if ! python3 -c "import distributed" 2>/dev/null; then
    echo "ci/test.sh: installing dask.distributed for the farm test"
    python3 -m pip install -q "distributed==2024.12.1" || true
fi
if python3 -c "import distributed" 2>/dev/null; then
    cargo build --release "${feature_args[@]}" --bin pathlight
    python3 farm/test_farm.py
elif [ "${CI:-}" = true ]; then
    echo "ci/test.sh: CI=true but dask.distributed could not be installed; the farm test cannot run" >&2
    exit 1
else
    echo "ci/test.sh: SKIPPED the farm test: no Python 3 with dask.distributed (pip install distributed)" >&2
fi
