// The parameter tree as documents, derived from the groups' declarations
// (common/piezoloop/params/groups.hpp): a JSON Schema (draft 2020-12) that
// other clients use to name and check parameters (`piezoloop schema`), and
// the Markdown tables of docs/protocol.md (`piezoloop schema --markdown`;
// a test fails when the committed tables differ).
#pragma once

#include <string>

#include <nlohmann/json.hpp>

namespace piezoloop::hostlink {

// Every group and field with type, unit, range, default and whether it is
// limit-critical ("limitCritical"); the wire type as "wire".
nlohmann::json parameter_schema();

// One table per group: field path, wire type, unit, allowed range, default,
// limit-critical, description; with each group's layout size.
std::string parameter_tables_markdown();

}  // namespace piezoloop::hostlink
