#pragma once
// Section tables from CSV files (Beam.stations_file, AeroSurface.stations_file): a blade's
// structural or aerodynamic stations kept as the spreadsheet they come in. LoadStationFiles
// turns each file into the `stations` list beside it, so that no reader knows about files.
#include <filesystem>
#include <functional>
#include <string>

#include "scenario.pb.h"

namespace cosim::interface {

// For every message below `proto` with `stations_file` set: reads the CSV (`resolve` turns the
// given path into the file to open), one station per row, the header naming the station
// message's fields (e.g. "s,ea,gj,ei_flap,ei_lag,mass,twist"; any order, any subset; an empty
// cell leaves the field at its default; lines starting with '#' and blank lines are skipped),
// appends them to `stations` and clears `stations_file`. `fail(path, message)` must throw: for a
// file that cannot be read, `stations` given too, an unknown column (the fields are listed), a
// repeated column, a row of another length or a cell that is not a finite number (the file's
// line and the column are named).
void LoadStationFiles(scenario::Scenario* proto,
                      const std::function<std::filesystem::path(const std::string&)>& resolve,
                      const std::function<void(const std::string&, const std::string&)>& fail);

}  // namespace cosim::interface
