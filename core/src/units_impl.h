/* Private extensions of the units module (units.c) used by the parameter validator. */
#ifndef EJ_UNITS_IMPL_H
#define EJ_UNITS_IMPL_H

#include "core_impl.h"

/* ej_units_parse with the value's name in the messages: subject is e.g. "'spacing' in set
 * 'soil'" ("<subject> expects a length (m), got '4 GPa' (a pressure)"); NULL for none. */
ej_err ej_units_parse_as(const char *text, const char *declared_unit, const ej_loc *loc, const char *subject,
                         double *si);
/* SI value of one declared unit ("deg" -> pi/180, "g/cm^3" -> 1000); false for an expression
 * that does not parse. Table defaults and bounds are in the declared unit; this converts. */
bool ej_units_scale(const char *unit, double *scale);

#endif /* EJ_UNITS_IMPL_H */
