#include "interface/base/text.h"

#include <charconv>

namespace cosim::interface {

std::string FormatNumber(double value) {
  char buffer[64];
  const auto result = std::to_chars(buffer, buffer + sizeof(buffer), value);
  return std::string(buffer, result.ptr);
}

std::string EchoedText(const std::string& text) {
  constexpr size_t kLimit = 200;
  size_t cut = text.size();
  if (cut > kLimit) {
    cut = kLimit;
    while (cut > 0 && (static_cast<unsigned char>(text[cut]) & 0xC0) == 0x80) --cut;  // not inside a UTF-8 character
  }
  // Control characters shown as '?': a NUL ended the message where it stood (what() is a C
  // string), and a terminal's escape sequences are not the input's to send.
  std::string shown = text.substr(0, cut);
  for (char& c : shown) {
    if (static_cast<unsigned char>(c) < 0x20 || c == '\x7f') c = '?';
  }
  return cut == text.size() ? shown : shown + "… (" + std::to_string(text.size()) + " bytes)";
}

}  // namespace cosim::interface
