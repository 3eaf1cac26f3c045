#!/usr/bin/env bash
# The core and the firmware use no heap, no exceptions and no RTTI: none of
# the symbols that bring them in may be linked into an image.
#   check_no_heap.sh <elf>...
set -u
forbidden='^(malloc|free|calloc|realloc|_malloc_r|_free_r|_sbrk|_sbrk_r|_Znwj|_Znaj|_ZdlPv|_ZdaPv|_ZdlPvj|__cxa_allocate_exception|__cxa_throw|__cxa_begin_catch|__gxx_personality_v0|_ZTI.*|_ZTS.*)$'
passed=0 failed=0
for elf in "$@"; do
    if [ ! -f "$elf" ]; then
        echo "FAIL $elf: missing (build the firmware presets first)"; failed=$((failed + 1)); continue
    fi
    found=$(arm-none-eabi-nm --defined-only "$elf" | awk '{print $NF}' | grep -E "$forbidden" || true)
    if [ -n "$found" ]; then
        echo "FAIL $elf links:"; echo "$found"; failed=$((failed + 1))
    else
        passed=$((passed + 1))
    fi
done
echo "$passed passed, $failed failed"
[ "$failed" -eq 0 ]
