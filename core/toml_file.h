#pragma once
// Every TOML file facesynth reads (synth config, landmark mapping, landmark completion) goes
// through here. Debian's toml11 3.7 reads past its buffer on a literal string or quoted key that
// holds invalid UTF-8, and recurses once per nested array, inline table or dotted-key part until
// the stack runs out, so the text is checked first: valid UTF-8 (as TOML requires), no control
// characters outside tab and line endings, and nesting no deeper than kMaxTomlNesting.
#include <toml.hpp>

#include <cstddef>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>

namespace facesynth::core {

// Deepest nesting of tables and arrays accepted. Our files need 3; toml11 exhausts an 8 MB stack
// at about 1,000 levels under ASan and 5,000 in a release build.
inline constexpr int kMaxTomlNesting = 100;

// Offset of the first byte that is not part of a well-formed UTF-8 sequence (RFC 3629: no
// overlong forms, no surrogates, nothing above U+10FFFF, no truncated sequence), or nullopt.
[[nodiscard]] std::optional<std::size_t> first_invalid_utf8(std::string_view text);

// Throws core::Error ("<source>: line L, byte B: …") when toml11 must not see `text`.
void check_toml_text(std::string_view text, const std::string& source);

// Checks `text`, then parses it; toml11's syntax errors become core::Error naming `source`.
[[nodiscard]] toml::value parse_toml(const std::string& text, const std::string& source);

// Reads `path` whole and parses it as above; errors name the file.
[[nodiscard]] toml::value read_toml_file(const std::filesystem::path& path);

}  // namespace facesynth::core
