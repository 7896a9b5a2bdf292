#!/usr/bin/env bash
# The test command of the README and of .ci/run. The tests use tools
# outside Rust and fail (never skip) without them, so this checks them
# first and installs what is missing:
#   python3 with python-can and pyserial  tests/cli/python_interop.rs (python-can against our sim and logs)
#   tmux                                  tests/cli/dashboard_tmux.rs (the dashboard in a real terminal)
#   man (man-db)                          tests/cli/completions_man.rs (the man page renders)
#   bash, git                             tests/cli/completions_man.rs (completion, --version's commit)
# Installing uses pip, or apt-get as root / through sudo. Extra arguments go
# to `cargo test`, e.g. `scripts/test.sh --test cli pac_cli`.
set -euo pipefail
cd "$(dirname "$0")/.."

say() { echo "scripts/test.sh: $*" >&2; }

as_root() {
    if [ "$(id -u)" = 0 ]; then
        "$@"
    elif command -v sudo >/dev/null; then
        sudo "$@"
    else
        say "cannot install without root or sudo; please run: $*"
        exit 1
    fi
}

apt_updated=
apt_install() {
    command -v apt-get >/dev/null || { say "no apt-get here: please install $* yourself"; exit 1; }
    if [ -z "$apt_updated" ]; then
        as_root apt-get update -qq
        apt_updated=1
    fi
    as_root env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "$@" >/dev/null
}

command -v cargo >/dev/null || { say "cargo is missing: install a Rust toolchain from https://rustup.rs"; exit 1; }

for tool in python3 tmux man bash git; do
    if ! command -v "$tool" >/dev/null; then
        say "installing $tool"
        case $tool in
            man) apt_install man-db ;;
            *) apt_install "$tool" ;;
        esac
    fi
done

if ! python3 -c 'import can, serial' 2>/dev/null; then
    say "installing python-can and pyserial"
    python3 -m pip install --quiet python-can pyserial 2>/dev/null \
        || python3 -m pip install --quiet --user python-can pyserial 2>/dev/null \
        || apt_install python3-can python3-serial
fi
python3 -c 'import can, serial' || { say "python-can / pyserial still missing"; exit 1; }

# --install-only: stop here (CI runs `cargo test` itself, as the README shows).
[ "${1:-}" = --install-only ] && exit 0
cargo test --all-targets --no-fail-fast "$@"
