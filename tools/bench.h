/* The `relief bench` modes; each prints what it measured, on what, with how many runs. */
#pragma once

int bench_codec(int argc, char **argv);
int bench_decode(int argc, char **argv);
int bench_lod(int argc, char **argv);
