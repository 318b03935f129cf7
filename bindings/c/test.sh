#!/usr/bin/env bash
# bindings/c/test.sh: the C library's checks, as CI runs them.
#  1. include/vsaqem.h is what cbindgen makes of src/lib.rs (else: stale);
#  2. format and lints, host and thumbv7em;
#  3. the C example, built with gcc -Werror against the static library, runs
#     its checks (spheres: closed, genus 0, deterministic, every error status);
#  4. with ../shared/data: it reconstructs the bunny into a closed mesh, the
#     same, bit for bit, as `vsaqem reconstruct` writes;
#  5. the C firmware, linked by arm-none-eabi-gcc against the thumbv7em static
#     library, runs on QEMU's MPS2 AN386 board and must print a closed mesh.
set -euo pipefail
cd "$(dirname "$0")"
root=$(cd ../.. && pwd)
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
CBINDGEN_VERSION=0.29.4
if ! cbindgen --version 2>/dev/null | grep -q "$CBINDGEN_VERSION"; then
  cargo install cbindgen --locked --version "$CBINDGEN_VERSION"
fi

echo "--- header"
cbindgen --config cbindgen.toml --output "$tmp/vsaqem.h"
if ! diff -u include/vsaqem.h "$tmp/vsaqem.h"; then
  echo "FAIL: bindings/c/include/vsaqem.h is stale (above: what src/lib.rs gives); run bindings/c/build.sh"
  exit 1
fi
echo "include/vsaqem.h is current"

echo "--- fmt, clippy"
cargo fmt -- --check
cargo clippy --release -- -D warnings
cargo clippy --release --target thumbv7em-none-eabihf --lib -- -D warnings 2>&1 |
  grep -v "dropping unsupported crate type .cdylib." || true
# (grep eats clippy's status: check it again, quietly)
cargo clippy -q --release --target thumbv7em-none-eabihf --lib -- -D warnings 2>/dev/null

echo "--- host: C example"
cargo build --release
cflags=(-std=c11 -O2 -Wall -Wextra -Werror -Iinclude)
gcc "${cflags[@]}" examples/reconstruct.c target/release/libvsaqem.a -lm -lpthread -ldl \
  -o "$tmp/reconstruct"
"$tmp/reconstruct"
# The shared library too: the same program, linked dynamically.
gcc "${cflags[@]}" examples/reconstruct.c -Ltarget/release -lvsaqem -lm -o "$tmp/reconstruct_so"
LD_LIBRARY_PATH=target/release "$tmp/reconstruct_so" >/dev/null

data=$root/../shared/data/clouds
if [ -d "$data" ]; then
  echo "--- host: a shared cloud, against the CLI"
  (cd "$root" && cargo build --release -q -p vsaqem)
  "$root/target/release/vsaqem" reconstruct -q "$data/bunny.ply" -o "$tmp/bunny_cli.ply" >/dev/null
  "$tmp/reconstruct" "$data/bunny.ply" "$tmp/bunny_c.ply"
  python3 tests/same_mesh.py "$tmp/bunny_c.ply" "$tmp/bunny_cli.ply"
else
  echo "skipped: $data not found (the bunny against the CLI)"
fi

echo "--- thumbv7em: C firmware on QEMU (mps2-an386)"
cargo rustc --release --target thumbv7em-none-eabihf --crate-type staticlib 2>&1 |
  grep -v "dropping unsupported crate type" || true
lib=target/thumbv7em-none-eabihf/release/libvsaqem.a
test -s "$lib"
arm-none-eabi-gcc -mcpu=cortex-m4 -mthumb -mfloat-abi=hard -mfpu=fpv4-sp-d16 -O2 -Wall -Wextra \
  -Werror -ffreestanding -nostdlib -Wa,--noexecstack -Iinclude firmware/main.c "$lib" -lgcc \
  -L "$root/targets/firmware" -T link.x -Wl,--gc-sections -o "$tmp/firmware.elf"
arm-none-eabi-size "$tmp/firmware.elf"
if arm-none-eabi-nm "$tmp/firmware.elf" | grep -E '__rust_alloc|__rdl_alloc|__rg_alloc|\bmalloc\b'; then
  echo "FAIL: the C firmware has allocator symbols (above)"
  exit 1
fi
timeout 300 qemu-system-arm -machine mps2-an386 -cpu cortex-m4 -display none -monitor none \
  -serial none -semihosting-config enable=on,target=native -kernel "$tmp/firmware.elf" \
  </dev/null 2>&1 | tee "$tmp/firmware.log"
grep -q "closed manifold: yes" "$tmp/firmware.log"
echo "C library: every check holds"
