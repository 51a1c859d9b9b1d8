// `facesynth report` end to end: a tiny rendered dataset and small result files give one
// self-contained page (no outside references, balanced inline SVG, embedded images, every section);
// absent inputs give "missing" notes, corrupt ones a warning naming the file, a bad --dataset exit 1
// with no output file.
#include "common/test_data.h"
#include "core/atomic_file.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

namespace {

namespace fs = std::filesystem;
using facesynth::testkit::cli_path;
using facesynth::testkit::count_occurrences;
using facesynth::testkit::fresh_temp_dir;
using facesynth::testkit::run_command;

void expect_self_contained(const std::string& html) {
    EXPECT_EQ(html.rfind("<!DOCTYPE html>", 0), 0u);
    EXPECT_NE(html.find("</html>"), std::string::npos);
    EXPECT_EQ(html.find("http://"), std::string::npos);
    EXPECT_EQ(html.find("https://"), std::string::npos);
    EXPECT_EQ(html.find("<script"), std::string::npos);
    EXPECT_EQ(html.find("<link"), std::string::npos);
    EXPECT_EQ(html.find("url("), std::string::npos);
    // Every image is embedded.
    const std::string src = "src=\"";
    for (std::size_t at = html.find(src); at != std::string::npos; at = html.find(src, at + 1))
        EXPECT_EQ(html.compare(at + src.size(), 11, "data:image/"), 0) << html.substr(at, 32);
    EXPECT_EQ(count_occurrences(html, "<svg"), count_occurrences(html, "</svg>"));
    EXPECT_EQ(count_occurrences(html, "<section"), count_occurrences(html, "</section>"));
    // No NaN or infinity printed into plots or tables (image data aside).
    std::string text;
    for (std::size_t at = 0; at < html.size();) {
        const std::size_t data = html.find("base64,", at);
        text += html.substr(at, data == std::string::npos ? std::string::npos : data - at);
        if (data == std::string::npos) break;
        at = html.find('"', data);  // the data URI ends with the attribute
    }
    EXPECT_EQ(text.find("nan"), std::string::npos);
    EXPECT_EQ(text.find("inf\""), std::string::npos);
}

TEST(CmdReport, SelfContainedPageFromDatasetAndResults) {
    const fs::path dir = fresh_temp_dir("cmd_report");
    const fs::path data = dir / "data", evals = dir / "evals";
    const std::string fs_cli = cli_path().string();
    std::string out;
    ASSERT_EQ(run_command(fs_cli + " synth --model builtin --out " + data.string() +
                              " -n 6 --size 96 --seed 5 --quiet",
                          &out),
              0)
        << out;
    fs::create_directories(evals / "fit_sweep");
    ASSERT_EQ(run_command(fs_cli + " eval fit --model builtin --data " + data.string() + " --mode fixed --quiet --json " +
                              (evals / "eval_fit_fixed.json").string(),
                          &out),
              0)
        << out;
    for (const char* landmarks : {"7", "68"})
        for (const char* noise : {"0", "2"})
            ASSERT_EQ(run_command(fs_cli + " eval fit --model builtin --count 8 --landmarks " + landmarks + " --noise " + noise +
                                      " --quiet --json " + (evals / "fit_sweep" / (std::string("eval_") + landmarks + "_" + noise + ".json")).string(),
                                  &out),
                      0)
                << out;
    // eval landmarks' JSON and per-face CSV, in the documented shape (test_cmd_train runs the real command).
    std::ofstream(evals / "eval_landmarks_synthetic.json")
        << R"({"count": 4, "detector_misses": 1, "regressor1": "/x/ours.sdm", "nme_mean": 0.05, "nme_median": 0.04,
              "auc_008": 0.4, "failure_rate_008": 0.25, "ms_per_face": 3.1, "regressor2": "dlib", "regressor2_nme_mean": 0.03,
              "regressor2_nme_median": -1, "regressor2_auc_008": 0.5, "regressor2_failure_rate_008": 0.5, "regressor2_ms_per_face": 4})";
    std::ofstream(evals / "eval_landmarks_synthetic.nme.csv")
        << "key,yaw_deg,detected,regressor1,regressor2\n\"a,b\",10,1,0.02,0.01\nb,,1,0.04,0.03\nc,5,1,0.09,inf\nd,5,0,inf,inf\n";
    std::ofstream(evals / "eval_recognition.json")
        << R"({"matcher": "lbph", "identities": 5, "landmarks": "ground truth", "far": 0.01,
              "gallery0_yaw_0_10_frr_org": 0.1, "gallery0_yaw_0_10_frr_lm": 0.05,
              "gallery0_yaw_30_40_frr_org": 0.5, "gallery0_yaw_30_40_frr_lm": 0.2})";
    std::ofstream(evals / "eval_recognition.det.csv")
        << "gallery_deg,probe_yaw_low,probe_yaw_high,method,far,frr\n0,0,10,org,0.001,0.5\n0,0,10,org,0.01,0.1\n0,0,10,org,1,0\n"
           "0,0,10,lm,0.001,0.2\n0,0,10,lm,0.01,0.05\n0,0,10,lm,1,0\n";
    std::ofstream(evals / "eval_fit_broken.json") << "{ not json";
    ASSERT_EQ(run_command(fs_cli + " frontalise --quiet --landmarks pts " + (data / "images" / "s00000000.png").string() + " --out " +
                              (evals / "frontalised").string(),
                          &out),
              0)
        << out;

    const fs::path html_path = dir / "report.html";
    ASSERT_EQ(run_command(fs_cli + " report --out " + html_path.string() + " --dataset " + data.string() + " --evals " + evals.string(), &out), 0)
        << out;
    EXPECT_NE(out.find("eval_fit_broken.json"), std::string::npos) << out;  // a warning naming the corrupt file
    const std::string html = facesynth::core::read_file(html_path);
    expect_self_contained(html);
    for (const char* id : {"id=\"samples\"", "id=\"fit\"", "id=\"landmarks\"", "id=\"frontalise\"", "id=\"recognition\""})
        EXPECT_NE(html.find(id), std::string::npos) << id;
    EXPECT_NE(html.find("data:image/jpeg;base64,"), std::string::npos);  // the contact sheet
    EXPECT_NE(html.find("CED, synthetic"), std::string::npos);
    EXPECT_NE(html.find("ours.sdm"), std::string::npos);
    EXPECT_NE(html.find("DET, gallery at 0"), std::string::npos);
    EXPECT_NE(html.find("7 landmarks"), std::string::npos);
    EXPECT_NE(html.find("eval_fit_broken.json"), std::string::npos);
    EXPECT_NE(html.find("Frontalised: frontalised"), std::string::npos);
    EXPECT_NE(html.find("alt=\"s00000000 isomap\" src=\"data:image/png;base64,"), std::string::npos);
    EXPECT_NE(html.find("Missing:</b> the frontalisation benchmark"), std::string::npos);  // no eval_frontalise.json
    EXPECT_GE(count_occurrences(html, "<svg"), 6u);
}

TEST(CmdReport, WithoutInputsEverySectionSaysWhatIsMissing) {
    const fs::path dir = fresh_temp_dir("cmd_report_empty");
    fs::create_directories(dir / "empty");
    std::string out;
    ASSERT_EQ(run_command(cli_path().string() + " report --quiet --out " + (dir / "r.html").string() + " --evals " + (dir / "empty").string(), &out), 0)
        << out;
    const std::string html = facesynth::core::read_file(dir / "r.html");
    expect_self_contained(html);
    EXPECT_GE(count_occurrences(html, "class=\"missing\""), 5u);
    EXPECT_NE(html.find("facesynth eval fit"), std::string::npos);
}

TEST(CmdReport, BadInputsFailCleanlyWithoutOutput) {
    const fs::path dir = fresh_temp_dir("cmd_report_bad");
    fs::create_directories(dir / "not_a_dataset");
    std::string out;
    const fs::path html = dir / "r.html";
    EXPECT_EQ(run_command(cli_path().string() + " report --out " + html.string() + " --dataset " + (dir / "not_a_dataset").string(), &out), 1) << out;
    EXPECT_NE(out.find("not_a_dataset"), std::string::npos) << out;
    EXPECT_FALSE(fs::exists(html));
    EXPECT_EQ(run_command(cli_path().string() + " report --out " + html.string() + " --evals " + (dir / "nowhere").string(), &out), 2) << out;
    EXPECT_EQ(run_command(cli_path().string() + " report", &out), 2) << out;
    EXPECT_FALSE(fs::exists(html));
}

}  // namespace
