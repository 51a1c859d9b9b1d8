// Habits every command shares (docs/cli.md): --help everywhere, and --quiet spelled the same way
// (-q, --quiet) wherever a command has it, checked by walking the help of every command.
#include "common/test_data.h"

#include <gtest/gtest.h>

#include <sstream>
#include <string>
#include <vector>

namespace {

// The names listed under "Subcommands:" in a command's --help output.
std::vector<std::string> subcommands_in_help(const std::string& help) {
    std::vector<std::string> names;
    std::istringstream lines(help);
    std::string line;
    bool in_list = false;
    while (std::getline(lines, line)) {
        if (line.rfind("Subcommands:", 0) == 0) {
            in_list = true;
        } else if (in_list && line.rfind("  ", 0) == 0 && line.size() > 2 && line[2] != ' ') {
            names.push_back(line.substr(2, line.find(' ', 2) - 2));
        } else if (in_list && !line.empty() && line[0] != ' ') {
            in_list = false;
        }
    }
    return names;
}

TEST(CliHabits, EveryCommandHasHelpAndQuietIsAlsoDashQ) {
    std::vector<std::string> pending{""};
    int commands = 0, with_quiet = 0;
    while (!pending.empty()) {
        const std::string command = pending.back();
        pending.pop_back();
        std::string help;
        ASSERT_EQ(facesynth::testkit::run_command(facesynth::testkit::cli_path().string() + command + " --help", &help), 0) << command;
        ++commands;
        if (help.find("--quiet") != std::string::npos) {
            ++with_quiet;
            EXPECT_NE(help.find("-q,--quiet"), std::string::npos) << "facesynth" << command << ": --quiet without -q";
        }
        for (const std::string& sub : subcommands_in_help(help)) pending.push_back(command + " " + sub);
    }
    EXPECT_GE(commands, 30);  // the walk found the command tree, not just the top
    EXPECT_GE(with_quiet, 20);
}

}  // namespace
