#include <errno.h>
#include <string.h>

#include "../test_util.h"
#include "config.h"

static void test_defaults_and_values(void **state)
{
	struct reliefd_config c;
	char err[256] = "";
	reliefd_config_defaults(&c);
	assert_int_equal(c.budget_mib, 256);
	assert_int_equal(c.decode_workers, 1);
	assert_int_equal(reliefd_config_parse_string(&c, "[gpu]\ndevice = llvmpipe\nvalidation = yes\nbudget_mib = 64\n"
	                                             "decode_workers = 3\n", err, sizeof(err)), 0);
	assert_int_equal(c.decode_workers, 3);
	assert_string_equal(c.device, "llvmpipe");
	assert_true(c.validation);
	assert_int_equal(c.budget_mib, 64);
}

static void test_errors_name_the_line(void **state)
{
	struct reliefd_config c;
	char err[256];
	reliefd_config_defaults(&c);
	assert_int_equal(reliefd_config_parse_string(&c, "[gpu]\nbudget_mib = -5\n", err, sizeof(err)), -EINVAL);
	assert_non_null(strstr(err, "line 2"));
	assert_non_null(strstr(err, "budget_mib"));
	assert_int_equal(c.budget_mib, 256); /* nothing applied on failure */
	assert_int_equal(reliefd_config_parse_string(&c, "[gpu]\nbudgte_mib = 5\n", err, sizeof(err)), -EINVAL);
	assert_non_null(strstr(err, "unknown key"));
	assert_int_equal(reliefd_config_parse_string(&c, "[gpux]\ndevice = a\n", err, sizeof(err)), -EINVAL);
	assert_non_null(strstr(err, "unknown section"));
	assert_int_equal(reliefd_config_parse_string(&c, "[gpu]\njunk line\n", err, sizeof(err)), -EINVAL);
	assert_non_null(strstr(err, "line 2"));
	assert_int_equal(reliefd_config_parse_string(&c, "[gpu]\nvalidation = maybe\n", err, sizeof(err)), -EINVAL);
	assert_int_equal(reliefd_config_parse_string(&c, "[gpu]\ndecode_workers = 0\n", err, sizeof(err)), -EINVAL);
	assert_non_null(strstr(err, "decode_workers"));
	assert_int_equal(reliefd_config_parse_string(&c, "[gpu]\ndecode_workers = 9\n", err, sizeof(err)), -EINVAL);
	assert_int_equal(c.decode_workers, 1);
}

static void test_load_missing_file(void **state)
{
	struct reliefd_config c;
	char err[256];
	int fds = test_count_fds();
	reliefd_config_defaults(&c);
	assert_int_equal(reliefd_config_load(&c, "/nonexistent/reliefd.conf", err, sizeof(err)), -ENOENT);
	assert_non_null(strstr(err, "/nonexistent/reliefd.conf"));
	assert_int_equal(reliefd_config_load(&c, RELIEF_SOURCE_DIR "/config/reliefd.conf", err, sizeof(err)), 0);
	assert_int_equal(c.budget_mib, 256);
	/* A directory opens and reads as nothing: it once loaded as an empty configuration. */
	c.budget_mib = 99;
	assert_int_equal(reliefd_config_load(&c, RELIEF_SOURCE_DIR "/config", err, sizeof(err)), -EINVAL);
	assert_non_null(strstr(err, "config: not a regular file"));
	assert_int_equal(c.budget_mib, 99); /* untouched */
	assert_int_equal(test_count_fds(), fds);
}

int main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_defaults_and_values),
		cmocka_unit_test(test_errors_name_the_line),
		cmocka_unit_test(test_load_missing_file),
	};
	return cmocka_run_group_tests(tests, NULL, NULL);
}
