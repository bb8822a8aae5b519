/* Build-time generator of strip_terms.glsl, the straight-line body of
 * shaders/patch_strips.comp: the transition strip bounds of one block edge
 * (docs/lod.md, "Transition triangles: what bounds them"; patch_strips.comp says why
 * each bound holds; the CPU twin, common/strip_bound.c, holds the same terms in loops).
 *
 * Why generated: the bounds read about 260 samples per edge when written as loops, each
 * sample several times (once per level that uses it); loading each sample once into a
 * local and indexing the locals by loop counters needs the loops unrolled, which neither
 * glslang nor lavapipe's compiler does here (a CPU implementation then indexes such an
 * array lane by lane, slower than the loads it saves). So this program unrolls them: it
 * writes one local per sample a bound reads (106 loads an edge) and every term with
 * constant operands (about 2,900 terms an edge, most of them the coarse-edge strips'). The
 * expressions are the twin's, term for term, so that the results are bit-exact with it
 * (test_patch_cache compares them).
 *
 * The points where a strip may deviate most from a finer interior's triangulation, the
 * edge's own level or full resolution come from relief_strip_interior_points(),
 * relief_strip_fine_points(), relief_strip_full_points() and
 * relief_strip_interior_full_points() (common/strip_bound.c), which the twin uses too.
 *
 * Usage: relief-strip-terms-gen OUT.glsl. */
#include <stdarg.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "layout.h"
#include "strip_bound.h"

#define N RELIEF_BLOCK_CELLS /* BLOCK_CELLS of shaders/block_record.glsl */

static bool used[N + 1][N + 1]; /* [depth][along]: a sample some term reads */

/* The terms go to `out` when it is non-NULL; the samples they read are marked always. */
static FILE *out;

static void emit(const char *fmt, ...) __attribute__((format(printf, 1, 2)));

static void emit(const char *fmt, ...)
{
	if (!out)
		return;
	va_list ap;
	va_start(ap, fmt);
	vfprintf(out, fmt, ap);
	va_end(ap);
}

static const char *smp(int along, int depth)
{
	static char buf[8][24];
	static int next;
	char *b = buf[next++ % 8];
	used[depth][along] = true;
	snprintf(b, sizeof buf[0], "h%d_%d", depth, along);
	return b;
}

/* The twin's coarse_edge(so, si), unrolled. */
static void coarse_edge(int so, int si)
{
	emit("float coarse_edge_%d_%d()\n{\n\tfloat worst = 0.0;\n", so, si);
	for (int c0 = 0; c0 < N; c0 += so) {
		emit("\t{\n\t\tint h00 = %s;\n", smp(c0, 0));
		emit("\t\tfloat dx = float(%s - h00) / %d.0;\n", smp(c0 + so, 0), so);
		emit("\t\tfloat dy_lo = float(%s - h00) / %d.0;\n", smp(c0, so), so);
		emit("\t\tfloat dy_hi = float(%s - ", smp(c0 + so, so));
		emit("%s) / %d.0;\n", smp(c0 + so, 0), so);
		int first, last;
		relief_strip_ring(c0, so, si, &first, &last);
		for (int t = first; t <= last; t += si) {
			const int x = t - c0;
			emit("\t\t{\n\t\t\tfloat a = float(%s - h00) - dx * %d.0;\n", smp(t, si), x);
			if (x + si <= so)
				emit("\t\t\tworst = max(worst, abs(a - dy_lo * %d.0));\n", si);
			if (x >= si)
				emit("\t\t\tworst = max(worst, abs(a - dy_hi * %d.0));\n", si);
			emit("\t\t}\n");
		}
		emit("\t}\n");
	}
	emit("\treturn worst;\n}\n\n");
}

/* A float as a GLSL literal that reads back as the same float. */
static const char *literal(float v)
{
	static char buf[4][40];
	static int next;
	char *b = buf[next++ % 4];
	snprintf(b, sizeof buf[0], "%.9g", (double)v);
	if (!strpbrk(b, ".eEn"))
		strcat(b, ".0");
	return b;
}

/* The twin's row_eps(r), unrolled, as row_eps_<r>(). */
static void row_eps(int r)
{
	emit("float row_eps_%d()\n{\n\tfloat worst = 0.0;\n", r);
	for (int k = 0; k < N; k++) {
		emit("\tworst = max(worst, 0.5 * float(abs(%s + %s - ", smp(k, r), smp(k + 1, r + 1));
		emit("%s - %s)));\n", smp(k + 1, r), smp(k, r + 1));
	}
	emit("\treturn worst;\n}\n\n");
}

/* The twin's combination in relief_strip_bounds(): the charge of an edge at levels 1..4
 * from the block's errors eps_1..eps_4 (eps), eps_0 (e0, infinite where unknown) and the
 * metres per quantum q2. */
static void charges(void)
{
	emit("vec4 strip_charges(vec4 eps, float e0, float q2)\n{\n\tvec4 charge = vec4(0.0);\n"
	     "\tconst float inf = uintBitsToFloat(0x7f800000u);\n");
	for (int l = 1; l <= 4; l++)
		for (int i = 0; i < l; i++) {
			emit("\t{\n\t\tprecise float b1 = eps[%d] + q2 * coarse_edge_%d_%d();\n", l - 1, 1 << l, 1 << i);
			if (i == 0)
				emit("\t\tfloat ei = e0;\n");
			else
				emit("\t\tfloat ei = eps[%d];\n", i - 1);
			emit("\t\tprecise float b2 = isinf(ei) ? inf : ei + q2 * interior_edge_%d_%d();\n", 1 << l, 1 << i);
			if (i == 0) {
				emit("\t\tcharge[%d] = max(charge[%d], min(b1, b2));\n\t}\n", l - 1, l - 1);
				continue;
			}
			emit("\t\tprecise float b3 = isinf(e0) ? inf : e0 + q2 * interior_full_%d_%d();\n", 1 << l, 1 << i);
			emit("\t\tcharge[%d] = max(charge[%d], min(min(b1, b2), b3));\n\t}\n", l - 1, l - 1);
		}
	emit("\treturn charge;\n}\n\n");
}

/* The twin's fine_edge(so), unrolled. */
static void fine_edge(int so)
{
	const int c = 2 * so;
	emit("float fine_edge_%d()\n{\n\tfloat worst = 0.0;\n", so);
	for (int c0 = 0; c0 < N; c0 += c) {
		emit("\t{\n\t\tint o = %s;\n", smp(c0, 0));
		emit("\t\tfloat m = float(%s - o), cc = float(%s - o);\n", smp(c0 + so, 0), smp(c0 + c, 0));
		emit("\t\tfloat a = float(%s - o), b = float(%s - o);\n", smp(c0, c), smp(c0 + c, c));
		emit("\t\tfloat mid = abs(m - 0.5 * cc);\n\t\tworst = max(worst, mid);\n");
		if (c0 >= c && c0 + c <= N - c)
			emit("\t\tfloat e1 = abs(b + 2.0 * m - a - 2.0 * cc) / 3.0, e2 = abs(a + 2.0 * m - b) / 3.0;\n"
			     "\t\tworst = max(worst, max(mid, min(e1, e2)));\n");
		emit("\t}\n");
	}
	emit("\treturn worst;\n}\n\n");
}

/* The twin's list_deviation() over the points of one kind of column, unrolled, as
 * <name>(): interior_edge_<so>_<si> (relief_strip_interior_points()), interior_full_<so>_<si>
 * (relief_strip_interior_full_points()), fine_edge_level_<so> (relief_strip_fine_points()),
 * fine_edge_full_<so> (relief_strip_full_points()). */
enum column_kind { INTERIOR, COARSE_FULL, FINE_OWN, FINE_FULL };

static void list_deviation(enum column_kind kind, int so, int si)
{
	static struct relief_strip_point pts[4096];
	const bool coarse = kind == INTERIOR || kind == COARSE_FULL;
	const int column = coarse ? so : 2 * so;
	if (coarse)
		emit("float interior_%s_%d_%d()\n{\n\tfloat worst = 0.0;\n", kind == INTERIOR ? "edge" : "full", so, si);
	else
		emit("float fine_edge_%s_%d()\n{\n\tfloat worst = 0.0;\n", kind == FINE_OWN ? "level" : "full", so);
	for (int c0 = 0; c0 < N; c0 += column) {
		const int np = kind == INTERIOR      ? relief_strip_interior_points(so, si, c0, pts, 4096)
		               : kind == COARSE_FULL ? relief_strip_interior_full_points(so, si, c0, pts, 4096)
		               : kind == FINE_OWN    ? relief_strip_fine_points(so, c0, pts, 4096)
		                                     : relief_strip_full_points(so, c0, pts, 4096);
		if (np > 4096) {
			fprintf(stderr, "strip terms: %d points in a column\n", np);
			exit(1);
		}
		emit("\t{\n\t\tint ref = %s;\n", smp(c0, 0));
		for (int i = 0; i < np; i++) {
			const struct relief_strip_point *p = &pts[i];
			emit("\t\t{\n\t\t\tprecise float d = ");
			for (int k = 0; k < p->n; k++)
				emit("%s%s * float(%s - ref)", k ? " + " : "", literal(p->w[k]), smp(p->s[k][0], p->s[k][1]));
			emit(";\n\t\t\tworst = max(worst, abs(d));\n\t\t}\n");
		}
		emit("\t}\n");
	}
	emit("\treturn worst;\n}\n\n");
}

/* The twin's combination for fine-edge strips in relief_strip_bounds(): the charge of an
 * edge at levels 0..2 from eps_1..eps_4 (eps), eps_0 over the first two rows for the edge's
 * own level (e0_2) and for full resolution with every diagonal (e0), both infinite where
 * unknown, and the metres per quantum q2. */
static void fine_charges(void)
{
	emit("vec3 fine_charges(vec4 eps, float e0_2, float e0, float q2)\n{\n\tvec3 charge;\n"
	     "\tconst float inf = uintBitsToFloat(0x7f800000u);\n");
	for (int l = 0; l <= 2; l++) {
		emit("\t{\n\t\tprecise float b1 = eps[%d] + q2 * fine_edge_%d();\n", l, 1 << l);
		if (l == 0)
			emit("\t\tfloat el = e0_2;\n");
		else
			emit("\t\tfloat el = eps[%d];\n", l - 1);
		emit("\t\tprecise float b2 = isinf(el) ? inf : el + q2 * fine_edge_level_%d();\n", 1 << l);
		emit("\t\tprecise float b3 = isinf(e0) ? inf : e0 + q2 * fine_edge_full_%d();\n", 1 << l);
		emit("\t\tcharge[%d] = min(min(b1, b2), b3);\n\t}\n", l);
	}
	emit("\treturn charge;\n}\n\n");
}

static void terms(void)
{
	for (int so = 2; so <= N; so *= 2)
		for (int si = 1; si < so; si *= 2) {
			coarse_edge(so, si);
			list_deviation(INTERIOR, so, si);
			if (si > 1)
				list_deviation(COARSE_FULL, so, si);
		}
	row_eps(0);
	row_eps(1);
	charges();
	for (int so = 1; so <= 4; so *= 2) {
		fine_edge(so);
		list_deviation(FINE_OWN, so, 0);
		list_deviation(FINE_FULL, so, 0);
	}
	fine_charges();
}

int main(int argc, char **argv)
{
	if (argc != 2) {
		fprintf(stderr, "usage: %s OUT.glsl\n", argv[0]);
		return 2;
	}
	terms(); /* marks the samples */
	if (!(out = fopen(argv[1], "w"))) {
		perror(argv[1]);
		return 1;
	}
	emit("// Generated by shaders/strip_terms_gen.c at build time: do not edit.\n"
	     "// The samples the strip bounds of one block edge read (h<depth>_<along>, in quanta),\n"
	     "// loaded once by strip_load() through sample_height(), which patch_strips.comp\n"
	     "// defines; then the bounds.\n");
	int loads = 0;
	for (int d = 0; d <= N; d++)
		for (int a = 0; a <= N; a++)
			if (used[d][a]) {
				emit("int h%d_%d;\n", d, a);
				loads++;
			}
	emit("\n// %d samples\nvoid strip_load()\n{\n", loads);
	for (int d = 0; d <= N; d++)
		for (int a = 0; a <= N; a++)
			if (used[d][a])
				emit("\th%d_%d = sample_height(%d, %d);\n", d, a, a, d);
	emit("}\n\n");
	terms();
	if (fclose(out) != 0) {
		perror(argv[1]);
		return 1;
	}
	return 0;
}
