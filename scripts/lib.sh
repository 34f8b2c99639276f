# Shared by the scripts in scripts/: checks for the embedded tools without installing
# anything, and names what is missing with the command that installs it.

# need TOOL INSTALL-HINT: records a missing executable.
missing=()
need() {
  if ! command -v "$1" >/dev/null 2>&1; then
    missing+=("$1 — install with: $2")
  fi
}

# need_target TRIPLE [TOOLCHAIN]: records a missing rustup target.
need_target() {
  local toolchain="${2:-}"
  if ! rustup ${toolchain:++$toolchain} target list --installed 2>/dev/null | grep -qx "$1"; then
    missing+=("Rust target $1${toolchain:+ ($toolchain)} — install with: rustup ${toolchain:++$toolchain }target add $1")
  fi
}

# report_missing SCRIPT: prints what is missing and exits 2, or returns.
report_missing() {
  if ((${#missing[@]})); then
    echo "$1: missing tools (nothing is installed automatically; .ci/run installs them):" >&2
    printf '  - %s\n' "${missing[@]}" >&2
    exit 2
  fi
}
