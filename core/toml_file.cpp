#include "core/toml_file.h"

#include "core/atomic_file.h"
#include "core/error.h"

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <sstream>
#include <vector>

namespace facesynth::core {
namespace {

bool is_continuation(unsigned char byte) { return (byte & 0xC0U) == 0x80U; }

// Length of the well-formed UTF-8 sequence starting at `at`, or 0 when there is none (RFC 3629,
// table 3-7 of the Unicode standard: the second byte's range depends on the first).
std::size_t sequence_length(std::string_view text, std::size_t at) {
    const auto byte = [&](std::size_t k) { return static_cast<unsigned char>(text[at + k]); };
    const unsigned char lead = byte(0);
    if (lead < 0x80U) return 1;
    std::size_t length = 0;
    unsigned char second_min = 0x80U;
    unsigned char second_max = 0xBFU;
    if (lead >= 0xC2U && lead <= 0xDFU) {
        length = 2;
    } else if (lead >= 0xE0U && lead <= 0xEFU) {
        length = 3;
        if (lead == 0xE0U) second_min = 0xA0U;  // below: overlong
        if (lead == 0xEDU) second_max = 0x9FU;  // above: UTF-16 surrogates
    } else if (lead >= 0xF0U && lead <= 0xF4U) {
        length = 4;
        if (lead == 0xF0U) second_min = 0x90U;  // below: overlong
        if (lead == 0xF4U) second_max = 0x8FU;  // above: beyond U+10FFFF
    } else {
        return 0;  // a continuation byte, an overlong 2-byte lead (C0, C1) or F5..FF
    }
    if (text.size() - at < length) return 0;  // truncated
    if (byte(1) < second_min || byte(1) > second_max) return 0;
    for (std::size_t k = 2; k < length; ++k)
        if (!is_continuation(byte(k))) return 0;
    return length;
}

// "line L, byte B" (both 1-based) for an error message.
std::string position(std::string_view text, std::size_t offset) {
    const std::string_view before = text.substr(0, offset);
    const auto line = 1 + std::count(before.begin(), before.end(), '\n');
    const auto line_start = before.rfind('\n');
    const std::size_t column = line_start == std::string_view::npos ? offset + 1 : offset - line_start;
    return "line " + std::to_string(line) + ", byte " + std::to_string(column);
}

// TOML allows no control character except tab, LF and CR (in CRLF), anywhere.
std::optional<std::size_t> first_control_character(std::string_view text) {
    for (std::size_t i = 0; i < text.size(); ++i) {
        const auto byte = static_cast<unsigned char>(text[i]);
        if ((byte < 0x20U && byte != '\t' && byte != '\n' && byte != '\r') || byte == 0x7FU) return i;
    }
    return std::nullopt;
}

// Offset just past the string that opens at `at` ("…", '…', """…""" or '''…'''), or the line
// break that ends an unterminated one-line string, or the end of the text.
std::size_t end_of_string(std::string_view text, std::size_t at) {
    const char quote = text[at];
    const bool escapes = quote == '"';
    const std::string triple(3, quote);
    std::size_t i = at + 1;
    if (text.compare(at, 3, triple) == 0) {
        i = at + 3;
        while (i < text.size()) {
            if (escapes && text[i] == '\\') {
                i += 2;
            } else if (text.compare(i, 3, triple) == 0) {
                i += 3;
                // A closing delimiter may carry one or two quotes of the string's own ("""a"""").
                for (int extra = 0; extra < 2 && i < text.size() && text[i] == quote; ++extra) ++i;
                return i;
            } else {
                ++i;
            }
        }
        return text.size();
    }
    while (i < text.size() && text[i] != '\n') {
        if (escapes && text[i] == '\\') {
            i += 2;
        } else if (text[i] == quote) {
            return i + 1;
        } else {
            ++i;
        }
    }
    return std::min(i, text.size());
}

struct OpenContainer {
    char kind;        // '[' array, '{' inline table
    int inner_depth;  // nesting of what it holds
};

// Where the nesting toml11 would build first exceeds kMaxTomlNesting: table header parts, dotted
// key parts and open arrays and inline tables add up; strings and comments are skipped. On valid
// TOML this follows toml11's reading; on invalid text toml11 stops at the first error, and up to
// there the two agree.
std::optional<std::size_t> first_too_deep(std::string_view text) {
    std::vector<OpenContainer> open;
    int table_depth = 0;  // the table the last header named (root: 0)
    int depth = 0;
    bool reading_key = true;
    bool line_start = true;
    std::size_t i = 0;
    while (i < text.size()) {
        const char c = text[i];
        if (c == '\n') {
            if (open.empty()) {
                depth = table_depth;
                reading_key = true;
                line_start = true;
            }
            ++i;
            continue;
        }
        if (c == ' ' || c == '\t' || c == '\r') {
            ++i;
            continue;
        }
        if (c == '#') {
            i = std::min(text.find('\n', i), text.size());
            continue;
        }
        if (c == '"' || c == '\'') {
            i = end_of_string(text, i);
            line_start = false;
            continue;
        }
        if (line_start && open.empty() && c == '[') {  // [a.b] or [[a.b]]
            depth = text.compare(i, 2, "[[") == 0 ? 2 : 1;
            for (++i; i < text.size() && text[i] != ']' && text[i] != '\n';) {
                if (text[i] == '"' || text[i] == '\'') {
                    i = end_of_string(text, i);
                    continue;
                }
                if (text[i] == '.' && ++depth > kMaxTomlNesting) return i;
                ++i;
            }
            if (depth > kMaxTomlNesting) return i;
            table_depth = depth;
            line_start = false;
            continue;
        }
        line_start = false;
        if (c == ']' || c == '}') {
            if (!open.empty()) open.pop_back();
            depth = open.empty() ? table_depth : open.back().inner_depth;
            reading_key = false;
        } else if (reading_key) {
            if (c == '.' && ++depth > kMaxTomlNesting) return i;
            if (c == '=') reading_key = false;
        } else if (c == '[' || c == '{') {
            if (++depth > kMaxTomlNesting) return i;
            open.push_back({c, depth});
            reading_key = c == '{';
        } else if (c == ',' && !open.empty()) {
            depth = open.back().inner_depth;
            reading_key = open.back().kind == '{';
        }
        ++i;
    }
    return std::nullopt;
}

}  // namespace

std::optional<std::size_t> first_invalid_utf8(std::string_view text) {
    for (std::size_t i = 0; i < text.size();) {
        const std::size_t length = sequence_length(text, i);
        if (length == 0) return i;
        i += length;
    }
    return std::nullopt;
}

void check_toml_text(std::string_view text, const std::string& source) {
    if (const auto at = first_invalid_utf8(text))
        throw file_error(source, position(text, *at) + ": not valid UTF-8 (TOML files must be UTF-8)");
    if (const auto at = first_control_character(text)) {
        char code[8];
        std::snprintf(code, sizeof code, "0x%02X", static_cast<unsigned>(static_cast<unsigned char>(text[*at])));
        throw file_error(source, position(text, *at) + ": control character " + code +
                                     " (TOML allows only tab and line breaks)");
    }
    if (const auto at = first_too_deep(text))
        throw file_error(source, position(text, *at) + ": tables and arrays nested more than " +
                                     std::to_string(kMaxTomlNesting) + " deep");
}

toml::value parse_toml(const std::string& text, const std::string& source) {
    check_toml_text(text, source);
    try {
        std::istringstream stream(text);
        return toml::parse(stream, source);
    } catch (const toml::exception& e) {
        throw file_error(source, std::string("TOML error: ") + e.what());
    }
}

toml::value read_toml_file(const std::filesystem::path& path) {
    return parse_toml(read_file(path), path.string());
}

}  // namespace facesynth::core
