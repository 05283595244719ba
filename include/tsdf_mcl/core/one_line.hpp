#pragma once
// Echoed user text in one-line errors.
#include <string>

namespace tsdf_mcl {

// `text` as one line of printable text: control characters (a newline in a path, an option value or a field name)
// become \n, \r, \t or \xNN, bytes that are not UTF-8 (binary bytes in a file header) \xNN. Valid UTF-8 (a name in
// another script) is kept. Every error the CLI or the node prints goes through it, so an error stays one line
// whatever user text it echoes.
std::string one_line(const std::string& text);

}  // namespace tsdf_mcl
