/* Units: every unit of the table, products, quotients and powers, plain numbers in the
 * declared unit, and each error class with its message. */
#include <check.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core_impl.h"

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

static const ej_loc test_loc = {"scene.yaml", 3, 7};

static double si_of(const char *text, const char *unit)
{
  double v = NAN;
  ej_err rc = ej_units_parse(text, unit, &test_loc, &v);
  const ej_error_frame *f = ej_error_cause();
  ck_assert_msg(rc == EJ_OK, "'%s' as %s: %s", text, unit, f ? f->msg : "?");
  return v;
}

#define ck_assert_rel(a, b) ck_assert_msg(fabs((a) - (b)) <= 1e-12 * fabs(b), "%.17g != %.17g", (a), (b))

/* Parses text, expects an input error at test_loc whose message contains want. */
static void expect_error(const char *text, const char *unit, const char *want)
{
  double v = 0;
  ej_err rc = ej_units_parse(text, unit, &test_loc, &v);
  ck_assert_int_eq(rc, EJ_ERR_INPUT);
  const ej_error_frame *f = ej_error_cause();
  ck_assert_ptr_nonnull(f);
  ck_assert_msg(strstr(f->msg, want), "'%s': message '%s' lacks '%s'", text, f->msg, want);
  ck_assert_int_eq(f->where.line, 3);
  ck_assert_int_eq(f->where.col, 7);
  ck_assert_str_eq(f->where.file, "scene.yaml");
  ej_error_clear();
}

START_TEST(test_lengths_times_masses)
{
  ck_assert_rel(si_of("4 mm", "m"), 4e-3);
  ck_assert_rel(si_of("2 m", "m"), 2.0);
  ck_assert_rel(si_of("3 cm", "m"), 3e-2);
  ck_assert_rel(si_of("7 um", "m"), 7e-6);
  ck_assert_rel(si_of("1.5 km", "m"), 1500.0);
  ck_assert_rel(si_of("0.25 us", "s"), 0.25e-6);
  ck_assert_rel(si_of("0.8 ms", "s"), 0.8e-3);
  ck_assert_rel(si_of("5 ns", "s"), 5e-9);
  ck_assert_rel(si_of("2 s", "s"), 2.0);
  ck_assert_rel(si_of("3 kg", "kg"), 3.0);
  ck_assert_rel(si_of("3 g", "kg"), 3e-3);
  ck_assert_rel(si_of("3 mg", "kg"), 3e-6);
}
END_TEST

START_TEST(test_pressures_energies)
{
  ck_assert_rel(si_of("8.7 GPa", "Pa"), 8.7e9);
  ck_assert_rel(si_of("98.5 MPa", "Pa"), 98.5e6);
  ck_assert_rel(si_of("101.325 kPa", "Pa"), 101325.0);
  ck_assert_rel(si_of("2.5e9 Pa", "Pa"), 2.5e9);
  ck_assert_rel(si_of("2 bar", "Pa"), 2e5);
  ck_assert_rel(si_of("3 N", "kg*m/s^2"), 3.0);
  ck_assert_rel(si_of("1 kg*m/s^2", "N"), 1.0);
  ck_assert_rel(si_of("4 J", "J"), 4.0);
  ck_assert_rel(si_of("4 kJ", "J"), 4e3);
  ck_assert_rel(si_of("4 MJ", "J"), 4e6);
  ck_assert_rel(si_of("4 GJ", "J"), 4e9);
  ck_assert_rel(si_of("6 W", "J/s"), 6.0);
  ck_assert_rel(si_of("300 K", "K"), 300.0);
  /* energy density shares the pressure dimension */
  ck_assert_rel(si_of("8.7 GJ/m^3", "J/m^3"), 8.7e9);
  ck_assert_rel(si_of("8.7 GPa", "J/m^3"), 8.7e9);
  ck_assert_rel(si_of("5 J/kg", "J/kg"), 5.0);
  ck_assert_rel(si_of("5 MJ/kg", "J/kg"), 5e6);
}
END_TEST

START_TEST(test_quotients_powers)
{
  ck_assert_rel(si_of("1.6 g/cm^3", "kg/m^3"), 1600.0);
  ck_assert_rel(si_of("1601", "kg/m^3"), 1601.0);
  ck_assert_rel(si_of("1 kg/m^3", "kg/m^3"), 1.0);
  ck_assert_rel(si_of("1 kg*m^-3", "kg/m^3"), 1.0);
  ck_assert_rel(si_of("100 m/s", "m/s"), 100.0);
  ck_assert_rel(si_of("3 km/s", "m/s"), 3000.0);
  ck_assert_rel(si_of("2 mm/us", "m/s"), 2000.0);
  ck_assert_rel(si_of("-9.81 m/s^2", "m/s^2"), -9.81);
  ck_assert_rel(si_of("1 m/s/s", "m/s^2"), 1.0);
  ck_assert_rel(si_of("2 1/s", "1/s"), 2.0);
  ck_assert_rel(si_of("4  mm ", "m"), 4e-3);
  ck_assert_rel(si_of("  4 kg / m^3", "kg/m^3"), 4.0);
  ck_assert(ej_units_compatible("J/m^3", "Pa"));
  ck_assert(ej_units_compatible("J/kg", "m^2/s^2"));
  ck_assert(ej_units_compatible("deg", "rad"));
  ck_assert(!ej_units_compatible("m", "s"));
  ck_assert(!ej_units_compatible("1", "deg"));
  ck_assert(!ej_units_compatible("mmm", "m"));
}
END_TEST

START_TEST(test_plain_numbers_and_angles)
{
  ck_assert_rel(si_of("5", "Pa"), 5.0);
  ck_assert_rel(si_of("1e-3", "m"), 1e-3);
  ck_assert_rel(si_of("+.5", "1"), 0.5);
  ck_assert_rel(si_of("3.", "1"), 3.0);
  ck_assert_rel(si_of("-2E2", "s"), -200.0);
  ck_assert_rel(si_of("0.3", "1"), 0.3);
  ck_assert_rel(si_of("30", "deg"), M_PI / 6);
  ck_assert_rel(si_of("30 deg", "deg"), M_PI / 6);
  ck_assert_rel(si_of("0.5 rad", "deg"), 0.5);
  ck_assert_rel(si_of("0.5", "rad"), 0.5);
  ck_assert_rel(si_of("90 deg", "rad"), M_PI / 2);
  ck_assert_rel(si_of("4mm", "m"), 4e-3);
}
END_TEST

START_TEST(test_errors)
{
  expect_error("abc", "m", "expected a number, got 'abc'");
  expect_error("", "m", "expected a number, got ''");
  expect_error("nan", "1", "expected a number, got 'nan'");
  expect_error("inf", "Pa", "expected a number, got 'inf'");
  expect_error("-infinity", "Pa", "expected a number");
  expect_error("0x10", "1", "expected a number");
  expect_error("1,000", "1", "expected a number, got '1,000'");
  expect_error("1e999", "1", "out of the range");
  expect_error("4 mmm", "m", "unknown unit 'mmm'");
  expect_error("4 mmm", "m", "did you mean 'mm'?");
  expect_error("4 furlong", "m", "known units: m, cm");
  expect_error("4 m^", "m", "malformed unit");
  expect_error("4 m//s", "m/s", "malformed unit");
  expect_error("4 GPa", "m", "expects a length (m), got '4 GPa' (a pressure)");
  expect_error("4 mm", "s", "expects a time (s), got '4 mm' (a length)");
  expect_error("4 s", "kg", "expects a mass (kg), got '4 s' (a time)");
  expect_error("4 m", "Pa", "expects a pressure (Pa), got '4 m' (a length)");
  expect_error("4 m", "kg/m^3", "expects a density (kg/m^3)");
  expect_error("4 m", "J", "expects an energy (J)");
  expect_error("4 Pa", "J/kg", "expects a specific energy (J/kg), got '4 Pa' (a pressure)");
  expect_error("4 J/kg", "J/m^3", "expects an energy density (J/m^3), got '4 J/kg' (a specific energy)");
  expect_error("4 GJ/m^3", "m", "(an energy density)");
  expect_error("4 m/s^2", "m/s", "expects a velocity (m/s), got '4 m/s^2' (an acceleration)");
  expect_error("4 m/s", "m/s^2", "expects an acceleration (m/s^2), got '4 m/s' (a velocity)");
  expect_error("4 m", "deg", "expects an angle (deg)");
  expect_error("4 deg", "K", "expects a temperature (K), got '4 deg' (an angle)");
  expect_error("4 mm", "1", "expects a plain number without unit, got '4 mm' (a length)");
  expect_error("30 deg", "1", "(an angle)");
  ck_assert_rel(si_of("4", "m/m"), 4.0);
}
END_TEST

START_TEST(test_bad_declared_unit)
{
  double v;
  ck_assert_int_eq(ej_units_parse("4", "furlong", &test_loc, &v), EJ_ERR_ARG);
  ej_error_clear();
}
END_TEST

int main(void)
{
  Suite *s = suite_create("units");
  TCase *tc = tcase_create("units");
  tcase_add_test(tc, test_lengths_times_masses);
  tcase_add_test(tc, test_pressures_energies);
  tcase_add_test(tc, test_quotients_powers);
  tcase_add_test(tc, test_plain_numbers_and_angles);
  tcase_add_test(tc, test_errors);
  tcase_add_test(tc, test_bad_declared_unit);
  suite_add_tcase(s, tc);
  SRunner *sr = srunner_create(s);
  srunner_run_all(sr, CK_NORMAL);
  int failed = srunner_ntests_failed(sr);
  srunner_free(sr);
  return failed ? EXIT_FAILURE : EXIT_SUCCESS;
}
