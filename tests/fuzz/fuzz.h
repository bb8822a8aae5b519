/* Every fuzz target defines LLVMFuzzerTestOneInput. Built two ways: with libFuzzer
 * (clang, -DRELIEF_FUZZ=ON) to search for crashes, and always with replay.c as a plain
 * program that ctest runs over the target's committed corpus (under ASan+UBSan too). */
#pragma once

#include <stddef.h>
#include <stdint.h>

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
