// What the command line prints on stderr is escaped for the terminal: a path or a key given by
// the user (or found in a file) may hold control characters that move the cursor or clear the
// screen, and bidirectional controls (U+202E RIGHT-TO-LEFT OVERRIDE, ...) that make a message
// read differently from what it says (issue 38). They are shown as \xNN or \uNNNN, as are bytes
// that are not UTF-8; newlines and tabs pass.
#pragma once

#include <memory>
#include <ostream>
#include <string>
#include <string_view>

namespace nephele::cli {

// `text` with C0 and C1 controls (but newline and tab), DEL, bidirectional and invisible
// formatting characters, and invalid UTF-8 escaped.
std::string terminalText(std::string_view text);

// Makes `stream` (std::cerr) escape everything written to it from here on, as terminalText
// does, a line at a time. The returned object restores the stream when it is destroyed.
std::shared_ptr<void> escapeStream(std::ostream& stream);

}  // namespace nephele::cli
