// The checked TOML reader every TOML file goes through (core/toml_file.h): the UTF-8 validator and
// the text checks that keep toml11 from reading past its buffer or exhausting the stack (the fuzzer
// finding that made them necessary is kept in tests/morph/test_eos_io.cpp, on the reader it hit).
#include "core/error.h"
#include "core/toml_file.h"

#include "common/model_files.h"
#include "common/test_data.h"

#include <gtest/gtest.h>

#include <functional>

using namespace facesynth;

namespace {

bool contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

std::string repeated(const std::string& unit, int times) {
    std::string out;
    for (int i = 0; i < times; ++i) out += unit;
    return out;
}

}  // namespace

TEST(Utf8, WellFormedTextIsAccepted) {
    EXPECT_EQ(core::first_invalid_utf8(""), std::nullopt);
    EXPECT_EQ(core::first_invalid_utf8("plain ascii = 1\n"), std::nullopt);
    EXPECT_EQ(core::first_invalid_utf8(std::string_view("nul \0 is a code point", 21)), std::nullopt);
    // 2, 3 and 4-byte forms, the edges of each range: U+0080, U+07FF, U+0800, U+D7FF, U+E000,
    // U+FFFF, U+10000, U+10FFFF.
    EXPECT_EQ(core::first_invalid_utf8("caf\xC3\xA9 \xE2\x82\xAC \xF0\x9D\x84\x9E"), std::nullopt);
    EXPECT_EQ(core::first_invalid_utf8("\xC2\x80\xDF\xBF\xE0\xA0\x80\xED\x9F\xBF\xEE\x80\x80\xEF\xBF\xBF"
                                 "\xF0\x90\x80\x80\xF4\x8F\xBF\xBF"),
              std::nullopt);
    EXPECT_EQ(core::first_invalid_utf8("\xEF\xBB\xBF" "a = 1"), std::nullopt);  // byte-order mark
}

TEST(Utf8, MalformedSequencesAreFoundAtTheirFirstByte) {
    struct Case {
        std::string text;
        std::size_t offset;
        const char* what;
    };
    const Case cases[] = {
        {"ab\xFF", 2, "FF is never UTF-8"},
        {"a\x80", 1, "lone continuation byte"},
        {"\xC0\xAF", 0, "overlong '/' (2 bytes)"},
        {"\xC1\xBF", 0, "overlong 2-byte lead C1"},
        {"x\xE0\x80\xAF", 1, "overlong '/' (3 bytes)"},
        {"\xF0\x80\x80\xAF", 0, "overlong '/' (4 bytes)"},
        {"\xF0\x8F\xBF\xBF", 0, "overlong U+FFFF (4 bytes)"},
        {"ok \xED\xA0\x80", 3, "UTF-16 high surrogate U+D800"},
        {"\xED\xBF\xBF", 0, "low surrogate U+DFFF"},
        {"\xF4\x90\x80\x80", 0, "U+110000, beyond Unicode"},
        {"\xF5\x80\x80\x80", 0, "lead F5"},
        {"\xC3", 0, "truncated 2-byte sequence at the end"},
        {"\xE2\x82", 0, "truncated 3-byte sequence at the end"},
        {"ab\xF0\x9F\x98", 2, "truncated 4-byte sequence at the end"},
        {"\xC3" "a", 0, "2-byte lead followed by ASCII"},
        {"\xE2\x82" "a", 0, "3-byte sequence cut by ASCII"},
        {"\xC3\xA9\xE2\x82\xAC\xE2\x28\xA1", 5, "bad second byte after valid characters"},
    };
    for (const auto& c : cases) EXPECT_EQ(core::first_invalid_utf8(c.text), c.offset) << c.what;
}

TEST(TomlFile, InvalidUtf8IsRefusedWhereverItStands) {
    // Literal strings, literal keys and multi-line literal strings are where toml11 over-reads;
    // the others it reports itself, but the message is ours everywhere.
    for (const std::string text : {"a = '7\xFF'\n", "'k\xFF' = 1\n", "a = '''x\n\xC0\xAF'''\n", "a = \"x\xFF\"\n",
                                   "a = \"\"\"\xED\xA0\x80\"\"\"\n", "a = 1 # \xFF\n", "\"k\xFF\" = 1\n", "[t\xFF]\n"}) {
        const std::string message = testkit::error_message_of([&] { (void)core::parse_toml(text, "s.toml"); });
        EXPECT_TRUE(contains(message, "s.toml: line ")) << message;
        EXPECT_TRUE(contains(message, "not valid UTF-8")) << message;
    }
    EXPECT_TRUE(contains(testkit::error_message_of([] { (void)core::parse_toml("a = 1\nb = 'x\xFF'\n", "s.toml"); }), "line 2, byte 7:"));
}

TEST(TomlFile, ControlCharactersAreRefusedByCode) {
    const std::string with_nul("a = \"x\0y\"\n", 10);
    EXPECT_TRUE(contains(testkit::error_message_of([&] { (void)core::parse_toml(with_nul, "n.toml"); }),
                         "n.toml: line 1, byte 7: control character 0x00"));
    EXPECT_TRUE(contains(testkit::error_message_of([] { (void)core::parse_toml("a = 1\n\x7F", "n.toml"); }), "line 2, byte 1: control character 0x7F"));
    EXPECT_TRUE(contains(testkit::error_message_of([] { (void)core::parse_toml("a = 1 # \x1B[31m\n", "n.toml"); }), "control character 0x1B"));
    // Tab, LF and CRLF are TOML's own.
    EXPECT_EQ(toml::find<int>(core::parse_toml("a\t=\t1\r\nb = 2\n", "ok.toml"), "b"), 2);
}

TEST(TomlFile, NestingIsBoundedBeforeToml11RecursesIntoIt) {
    // toml11 recurses once per level and exhausts the stack at about 1,000 levels under ASan.
    const auto too_deep = [](const std::string& text) {
        return contains(testkit::error_message_of([&] { (void)core::parse_toml(text, "deep.toml"); }),
                        "deep.toml: line 1, byte ");
    };
    EXPECT_TRUE(too_deep("a = " + repeated("[", 100000) + repeated("]", 100000) + "\n"));
    EXPECT_TRUE(too_deep("a = " + repeated("{b = ", 20000) + "1" + repeated("}", 20000) + "\n"));
    EXPECT_TRUE(too_deep(repeated("a.", 50000) + "a = 1\n"));
    EXPECT_TRUE(too_deep("[" + repeated("a.", 50000) + "a]\n"));
    EXPECT_TRUE(too_deep("[[" + repeated("a.", 200) + "a]]\n"));
    EXPECT_TRUE(too_deep("a = [{" + repeated("b.", 150) + "c = 1}]\n"));
    EXPECT_TRUE(contains(testkit::error_message_of([] { (void)core::parse_toml("a = " + repeated("[", 101) + repeated("]", 101), "d.toml"); }),
                         "byte 105: tables and arrays nested more than 100 deep"));
    // A closing ''' may carry two more quotes: what follows is structure, not a new string.
    EXPECT_TRUE(too_deep("a = ['''x'''', " + repeated("[", 150) + repeated("]", 150) + "]\n"));

    // The limit itself, and brackets and dots that are text, not structure.
    const toml::value deepest = core::parse_toml("a = " + repeated("[", 100) + "1" + repeated("]", 100) + "\n", "ok.toml");
    EXPECT_TRUE(toml::find(deepest, "a").is_array());
    const std::string brackets = repeated("[{.", 300);
    const toml::value text = core::parse_toml("a = \"" + brackets + "\"\nb = '" + brackets + "'\nc = \"\"\"\n" + brackets +
                                            "\"\"\"\nd = '''" + brackets + "'''\n# " + brackets + "\n\"" + brackets +
                                            "\" = 1\ne = \"\\\"" + brackets + "\"\n",
                                        "ok.toml");
    EXPECT_EQ(toml::find<std::string>(text, "b"), brackets);
    EXPECT_EQ(toml::find<std::string>(text, "e"), "\"" + brackets);
    // Arrays of many values and many tables are wide, not deep.
    std::string wide = "a = [";
    for (int i = 0; i < 500; ++i) wide += "[1.5, {x.y = 2}], ";
    wide += "]\n";
    for (int i = 0; i < 200; ++i) wide += "[t" + std::to_string(i) + ".u.v]\nw = [[1], [2]]\n";
    EXPECT_EQ(toml::find(core::parse_toml(wide, "wide.toml"), "a").as_array().size(), 500U);
}

TEST(TomlFile, SyntaxErrorsAndMissingFilesNameTheFile) {
    EXPECT_TRUE(contains(testkit::error_message_of([] { (void)core::parse_toml("a = = 1\n", "syntax.toml"); }), "syntax.toml: TOML error:"));
    const auto dir = testkit::fresh_temp_dir("toml_file");
    EXPECT_TRUE(contains(testkit::error_message_of([&] { (void)core::read_toml_file(dir / "missing.toml"); }), "missing.toml: cannot open"));
    testkit::write_bytes(dir / "good.toml", "[pose]\nyaw = -30.5\n");
    EXPECT_DOUBLE_EQ(toml::find<double>(core::read_toml_file(dir / "good.toml"), "pose", "yaw"), -30.5);
}
