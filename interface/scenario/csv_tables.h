#pragma once
// Tables from CSV files, kept as the spreadsheet they come in and turned into the scenario's own
// lists when it is read, so that no reader knows about files:
// - `stations_file` (Beam, AeroSurface): a blade's structural or aerodynamic stations, one per
//   row, into `stations`;
// - `grid_file` (Airwake): a survey's grid points, one per row, into `grid`;
// - `file` of a TimeFunction table: two named columns (time, value) into `time` and `value`.
#include <filesystem>
#include <functional>
#include <string>

#include "scenario.pb.h"

namespace cosim::interface {

// For every message below `proto` with one of the files above set: reads the CSV (`resolve`
// turns the given path into the file to open) and clears the file field. Row tables: the header
// names the row message's fields (e.g. "s,ea,gj,ei_flap,ei_lag,mass,twist"; any order, any
// subset; an empty cell leaves the field at its default). Column tables: the header names the
// columns, of which two are read (`time_column`, default "time", and `value_column`, the
// values times `value_scale`). Lines starting with '#' and blank lines are skipped.
// `fail(path, message)` must throw: for a file that cannot be read, the list given too, an
// unknown or missing column (the known ones are listed), a repeated column, a row of another
// length or a cell that is not a finite number (the file's line and the column are named).
void LoadCsvTables(scenario::Scenario* proto, const std::function<std::filesystem::path(const std::string&)>& resolve,
                   const std::function<void(const std::string&, const std::string&)>& fail);

}  // namespace cosim::interface
