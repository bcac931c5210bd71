#pragma once
// Text every message of the programs is made of: numbers as they read back, and input echoed
// within bounds.
#include <string>

namespace cosim::interface {

// Shortest text that reads back to the same double.
std::string FormatNumber(double value);

// A peer's or user's text as it may be echoed into a message, a log or a summary: whole up to
// 200 bytes, else its first 200 (cut at a character boundary) and its length, so that a 20 MB
// name cannot make a 20 MB summary.
std::string EchoedText(const std::string& text);

}  // namespace cosim::interface
