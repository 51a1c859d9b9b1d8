// Bad inputs through the real CLI (docs/robustness.md lists every one with the test that checks
// it): odd and broken images in a `detect` batch and an `eval landmarks` dataset, photographs too
// large to process, out-of-range parameters, unwritable output folders, bad model files, and
// OpenGL backends that cannot start. Each must give a clear one-line error and the right exit code,
// never a crash or an "internal error".
#include "common/model_files.h"
#include "common/test_data.h"
#include "core/atomic_file.h"

#include <gtest/gtest.h>
#include <jpeglib.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <zlib.h>

#include <cstdio>
#include <filesystem>
#include <fstream>

namespace {

namespace fs = std::filesystem;
using facesynth::core::read_file;
using facesynth::testkit::cli_path;
using facesynth::testkit::fresh_temp_dir;
using facesynth::testkit::read_json;
using facesynth::testkit::write_bytes;

int run_cli(const std::string& arguments, std::string* output) {
    return facesynth::testkit::run_command(cli_path().string() + " " + arguments, output);
}

bool contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

// A frontal built-in face, large in a 256² image, that the Haar detector finds.
fs::path rendered_face(const fs::path& dir) {
    std::string log;
    EXPECT_EQ(run_cli("render --size 256 --antialiasing none --quiet -o " + (dir / "render").string(), &log), 0) << log;
    return dir / "render" / "image.png";
}

// A CMYK JPEG (as print workflows save photographs), written with libjpeg.
void write_cmyk_jpeg(const fs::path& path, const cv::Mat& bgr) {
    std::vector<unsigned char> cmyk(bgr.total() * 4);
    for (int y = 0; y < bgr.rows; ++y)
        for (int x = 0; x < bgr.cols; ++x) {
            const auto& p = bgr.at<cv::Vec3b>(y, x);
            unsigned char* q = &cmyk[(static_cast<std::size_t>(y) * bgr.cols + x) * 4];
            // Adobe's inverted CMYK, as Photoshop writes it: 255 - C, 255 - M, 255 - Y, 255 - K, with K = 0.
            q[0] = p[2];
            q[1] = p[1];
            q[2] = p[0];
            q[3] = 255;
        }
    jpeg_compress_struct info{};
    jpeg_error_mgr errors{};
    info.err = jpeg_std_error(&errors);
    jpeg_create_compress(&info);
    std::FILE* file = std::fopen(path.c_str(), "wb");
    ASSERT_NE(file, nullptr);
    jpeg_stdio_dest(&info, file);
    info.image_width = static_cast<JDIMENSION>(bgr.cols);
    info.image_height = static_cast<JDIMENSION>(bgr.rows);
    info.input_components = 4;
    info.in_color_space = JCS_CMYK;
    jpeg_set_defaults(&info);
    jpeg_set_quality(&info, 95, TRUE);
    jpeg_start_compress(&info, TRUE);
    while (info.next_scanline < info.image_height) {
        JSAMPROW row = &cmyk[static_cast<std::size_t>(info.next_scanline) * bgr.cols * 4];
        jpeg_write_scanlines(&info, &row, 1);
    }
    jpeg_finish_compress(&info);
    jpeg_destroy_compress(&info);
    std::fclose(file);
}

// The start of a PNG whose header declares width x height 8-bit grey pixels; the pixel data is
// cut short (the file must be refused from its header, before any decoding).
std::string png_header_only(std::uint32_t width, std::uint32_t height) {
    const auto be32 = [](std::uint32_t v) {
        return std::string{static_cast<char>(v >> 24), static_cast<char>(v >> 16), static_cast<char>(v >> 8), static_cast<char>(v)};
    };
    const std::string ihdr = "IHDR" + be32(width) + be32(height) + std::string("\x08\x00\x00\x00\x00", 5);
    const auto crc = static_cast<std::uint32_t>(::crc32(0, reinterpret_cast<const Bytef*>(ihdr.data()), static_cast<uInt>(ihdr.size())));
    return std::string("\x89PNG\r\n\x1a\n", 8) + be32(13) + ihdr + be32(crc) + be32(1000) + "IDAT" + std::string(16, '\0');
}

TEST(Robustness, DetectBatchReportsEachBadImageAndGoesOn) {
    const auto dir = fresh_temp_dir("robust_detect");
    const fs::path face = rendered_face(dir);
    const cv::Mat bgr = cv::imread(face.string(), cv::IMREAD_COLOR);
    ASSERT_FALSE(bgr.empty());
    cv::Mat gray, deep;
    cv::cvtColor(bgr, gray, cv::COLOR_BGR2GRAY);
    bgr.convertTo(deep, CV_16UC3, 257.0);
    ASSERT_TRUE(cv::imwrite((dir / "gray.png").string(), gray));
    ASSERT_TRUE(cv::imwrite((dir / "deep16.png").string(), deep));
    write_cmyk_jpeg(dir / "cmyk.jpg", bgr);
    ASSERT_TRUE(cv::imwrite((dir / "tiny.png").string(), cv::Mat(1, 1, CV_8UC3, cv::Scalar(90, 120, 200))));
    write_bytes(dir / "text.png", "this is a text file with an image extension\n");
    write_bytes(dir / "empty.jpg", "");
    const std::string png = read_file(face);
    write_bytes(dir / "truncated.png", png.substr(0, png.size() / 2));
    write_bytes(dir / "huge.png", png_header_only(20000, 20000));

    const std::vector<std::string> readable = {"image", "gray", "deep16", "cmyk"};
    std::string images = face.string();
    for (const char* name : {"gray.png", "deep16.png", "cmyk.jpg", "tiny.png", "text.png", "empty.jpg", "truncated.png", "huge.png", "missing.png"})
        images.append(" ").append((dir / name).string());
    std::string log;
    EXPECT_EQ(run_cli("detect --regressor dlib " + images + " --out " + (dir / "out").string() + " --quiet", &log), 1) << log;
    EXPECT_FALSE(contains(log, "internal error")) << log;
    // Grey, 16-bit and CMYK versions of the face are read like the original: same face, same box.
    for (const auto& name : readable) EXPECT_TRUE(fs::exists(dir / "out" / (name + ".json"))) << name << "\n" << log;
    EXPECT_TRUE(contains(log, "tiny.png: no face found")) << log;
    for (const char* name : {"text.png", "empty.jpg", "truncated.png"})
        EXPECT_TRUE(contains(log, std::string(name) + ": cannot read image")) << name << "\n" << log;
    EXPECT_TRUE(contains(log, "huge.png: image is 20000 x 20000 pixels, more than the 100 megapixels")) << log;
    EXPECT_TRUE(contains(log, "missing.png: file not found")) << log;
    EXPECT_TRUE(contains(log, "6 of 10 images failed")) << log;
}

TEST(Robustness, EvalLandmarksCountsCorruptItemsAndExitsOne) {
    const auto dir = fresh_temp_dir("robust_eval");
    const fs::path data = dir / "data";
    std::string log;
    ASSERT_EQ(run_cli("synth --model builtin --out " + data.string() + " -n 4 --size 96 --seed 3 --format folder"
                  " --quiet", &log), 0) << log;
    const std::string png = read_file(data / "images" / "s00000001.png");
    write_bytes(data / "images" / "s00000001.png", png.substr(0, png.size() / 3));
    write_bytes(data / "landmarks" / "s00000002.pts", "version: 1\nn_points: 3\n{\n1 1\n2 2\n3 3\n}\n");
    const fs::path json = dir / "eval.json";
    EXPECT_EQ(run_cli("eval landmarks --regressor dlib --data " + data.string() + " --quiet --json " + json.string(), &log), 1) << log;
    EXPECT_TRUE(contains(log, "s00000001.png: cannot read image")) << log;
    EXPECT_TRUE(contains(log, "s00000002.pts: expected 68 points")) << log;
    EXPECT_TRUE(contains(log, "2 of 4 images or landmark files could not be read")) << log;
    EXPECT_FALSE(contains(log, "internal error")) << log;
    const auto report = read_json(json);  // the report is still written, counting them as misses
    EXPECT_EQ(report["count"], 4);
    EXPECT_EQ(report["unreadable"], 2);
}

TEST(Robustness, FitRefusesUnreadableAndHugeImagesByName) {
    const auto dir = fresh_temp_dir("robust_fit");
    const fs::path data = dir / "data";
    std::string log;
    ASSERT_EQ(run_cli("synth --model builtin --out " + data.string() + " -n 1 --size 64 --format folder --quiet", &log), 0) << log;
    const std::string pts = (data / "landmarks" / "s00000000.pts").string();
    write_bytes(dir / "text.jpg", "not a JPEG");
    write_bytes(dir / "huge.png", png_header_only(20000, 20000));
    ASSERT_TRUE(cv::imwrite((dir / "tiny.png").string(), cv::Mat(1, 1, CV_8UC3, cv::Scalar(1, 2, 3))));
    const std::string fit = "fit --model builtin --landmarks " + pts + " --quiet --out " + (dir / "out").string() + " --image ";
    EXPECT_EQ(run_cli(fit + (dir / "text.jpg").string(), &log), 1) << log;
    EXPECT_TRUE(contains(log, "text.jpg: cannot read the image")) << log;
    EXPECT_EQ(run_cli(fit + (dir / "huge.png").string(), &log), 1) << log;
    EXPECT_TRUE(contains(log, "huge.png: image is 20000 x 20000 pixels")) << log;
    // A 1x1 photograph is valid: the landmarks lie outside it, the overlay is just clipped.
    EXPECT_EQ(run_cli(fit + (dir / "tiny.png").string(), &log), 0) << log;
}

TEST(Robustness, FrontaliseRefusesHugeImagesByName) {
    const auto dir = fresh_temp_dir("robust_frontalise");
    const fs::path data = dir / "data";
    std::string log;
    ASSERT_EQ(run_cli("synth --model builtin --out " + data.string() + " -n 1 --size 64 --format folder --quiet", &log), 0) << log;
    write_bytes(dir / "huge.png", png_header_only(20000, 20000));
    const std::string pts = (data / "landmarks" / "s00000000.pts").string();
    EXPECT_EQ(run_cli("frontalise --model builtin --pts " + pts + " --quiet --out " + (dir / "out").string() + " " + (dir / "huge.png").string(), &log), 1) << log;
    EXPECT_TRUE(contains(log, "huge.png: image is 20000 x 20000 pixels")) << log;
}

TEST(Robustness, OutOfRangeParametersAreRefusedNamingThem) {
    const auto dir = fresh_temp_dir("robust_ranges");
    std::string log;
    EXPECT_EQ(run_cli("render --yaw 400 -o " + (dir / "r").string(), &log), 2) << log;
    EXPECT_TRUE(contains(log, "--yaw")) << log;
    EXPECT_EQ(run_cli("render --pitch -200 -o " + (dir / "r").string(), &log), 2) << log;
    EXPECT_EQ(run_cli("render --size -5 -o " + (dir / "r").string(), &log), 2) << log;
    EXPECT_EQ(run_cli("render --size 0 -o " + (dir / "r").string(), &log), 2) << log;
    EXPECT_EQ(run_cli("synth -o " + (dir / "s").string() + " -n 1 --set camera.width=-5", &log), 1) << log;
    EXPECT_TRUE(contains(log, "config key 'camera.width'")) << log;
    EXPECT_EQ(run_cli("synth -o " + (dir / "s").string() + " -n 1 --set pose.yaw.max=400", &log), 1) << log;
    EXPECT_TRUE(contains(log, "config key 'pose.yaw.max'")) << log;
    EXPECT_EQ(run_cli("synth -o " + (dir / "s").string() + " -n -3 --quiet", &log), 2) << log;  // not "the default count"
    EXPECT_TRUE(contains(log, "--count")) << log;
    EXPECT_FALSE(fs::exists(dir / "r"));
}

// CLI11 reads "nan" and "inf" as doubles, and a NaN passes every range check; the render used to
// exit 0 with a render.json full of nulls.
TEST(Robustness, NonFiniteNumbersAreRefusedNamingTheOptionOrKey) {
    const auto dir = fresh_temp_dir("robust_nonfinite");
    std::string log;
    for (const std::string arguments : {"render --yaw nan", "render --pitch inf", "render --roll -inf", "render --fov NaN",
                                        "render --yaw 1e999"}) {
        EXPECT_EQ(run_cli(arguments + " -o " + (dir / "r").string(), &log), 2) << arguments << ": " << log;
        const std::string option = arguments.substr(7, arguments.find(' ', 7) - 7);
        EXPECT_TRUE(contains(log, option)) << arguments << ": " << log;
    }
    EXPECT_EQ(run_cli("train --data " + dir.string() + " --out " + (dir / "m.sdm").string() + " --lambda-factors 3,nan", &log), 2) << log;
    EXPECT_TRUE(contains(log, "--lambda-factors")) << log;
    EXPECT_EQ(run_cli("fit --help", &log), 0);  // the check adds nothing to valid use
    EXPECT_EQ(run_cli("synth -o " + (dir / "s").string() + " -n 1 --set pose.yaw.max=inf", &log), 1) << log;
    EXPECT_TRUE(contains(log, "config key 'pose.yaw.max' must be a finite number")) << log;
    write_bytes(dir / "nan.toml", "[pose.yaw]\nmin = nan\n");
    EXPECT_EQ(run_cli("synth -o " + (dir / "s").string() + " -n 1 --config " + (dir / "nan.toml").string(), &log), 1) << log;
    EXPECT_TRUE(contains(log, "nan.toml: config key 'pose.yaw.min' must be a finite number")) << log;
    EXPECT_FALSE(fs::exists(dir / "r"));
    EXPECT_FALSE(fs::exists(dir / "s"));
}

TEST(Robustness, AntialiasingIsOneMethodWithABoundedSampleCountAndIsRecorded) {
    const auto dir = fresh_temp_dir("robust_antialiasing");
    std::string log;
    EXPECT_EQ(run_cli("render --size 64 --antialiasing fxaa -o " + (dir / "r").string(), &log), 2) << log;
    EXPECT_TRUE(contains(log, "--antialiasing")) << log;
    EXPECT_EQ(run_cli("render --size 64 --antialiasing supersampling --antialiasing-samples 8 -o " + (dir / "r").string(), &log), 2) << log;
    EXPECT_TRUE(contains(log, "--antialiasing-samples") && contains(log, "2 to 4")) << log;
    EXPECT_EQ(run_cli("render --size 64 --antialiasing edges --antialiasing-samples 4 -o " + (dir / "r").string(), &log), 2) << log;
    EXPECT_FALSE(fs::exists(dir / "r"));
    EXPECT_EQ(run_cli("bench render --size 64 -n 5 --bare --antialiasing edges --quiet", &log), 2) << log;
    EXPECT_TRUE(contains(log, "--antialiasing none")) << log;
    // synth's config: the keys the method replaced are named as replaced, a bad count names its key.
    EXPECT_EQ(run_cli("synth -o " + (dir / "s").string() + " -n 1 --set render.msaa_samples=4", &log), 1) << log;
    EXPECT_TRUE(contains(log, "render.msaa_samples' was replaced by render.antialiasing")) << log;
    EXPECT_EQ(run_cli("synth -o " + (dir / "s").string() + " -n 1 --set render.antialiasing=msaa --set render.antialiasing_samples=64", &log), 1) << log;
    EXPECT_TRUE(contains(log, "render.antialiasing_samples")) << log;
    EXPECT_FALSE(fs::exists(dir / "s" / "manifest.jsonl"));
    ASSERT_EQ(run_cli("render --size 64 --antialiasing edges --quiet -o " + (dir / "r").string(), &log), 0) << log;
    EXPECT_EQ(read_json(dir / "r" / "render.json")["antialiasing"], "edges");
    EXPECT_EQ(read_json(dir / "r" / "render.json")["antialiasing_samples"], 1);
    ASSERT_EQ(run_cli("render --size 64 --quiet -o " + (dir / "r2").string(), &log), 0) << log;
    EXPECT_EQ(read_json(dir / "r2" / "render.json")["antialiasing"], "msaa");  // the render command's default
    EXPECT_EQ(read_json(dir / "r2" / "render.json")["antialiasing_samples"], 4);
}

TEST(Robustness, UnwritableOutputIsAOneLineErrorNamingThePath) {
    const auto dir = fresh_temp_dir("robust_unwritable");
    // A path below a regular file cannot be created by anyone (permission bits do not stop root).
    write_bytes(dir / "blocker", "a file, not a folder");
    const std::string blocked = (dir / "blocker" / "sub").string();
    std::string log;
    for (const std::string& command : {"render --size 32 --antialiasing none -o " + blocked, "synth -n 1 --size 32 -o " + blocked,
                                       "model convert --model builtin --out " + blocked + "/m.fsm",
                                       "model info --model builtin --json " + blocked + "/info.json",
                                       "detect --regressor dlib " + (dir / "blocker").string() + " --out " + blocked}) {
        EXPECT_EQ(run_cli(command, &log), 1) << command << "\n" << log;
        EXPECT_TRUE(contains(log, "facesynth: error: ")) << command << "\n" << log;
        EXPECT_TRUE(contains(log, "blocker")) << command << "\n" << log;
        EXPECT_FALSE(contains(log, "internal error")) << command << "\n" << log;
    }
}

TEST(Robustness, BadModelFilesThroughTheCliNameTheFile) {
    const auto dir = fresh_temp_dir("robust_models");
    write_bytes(dir / "empty.fsm", "");
    write_bytes(dir / "text.h5", "not HDF5\n");
    write_bytes(dir / "short.bin", std::string("\x01\x00\x00\x00\x10\x00", 6));
    write_bytes(dir / "model.obj", "v 0 0 0\n");
    std::string log;
    for (const char* name : {"empty.fsm", "text.h5", "short.bin", "model.obj", "missing.fsm"}) {
        EXPECT_EQ(run_cli("model info --model " + (dir / name).string(), &log), 1) << name << "\n" << log;
        EXPECT_TRUE(contains(log, "facesynth: error: " + (dir / name).string())) << log;
        EXPECT_FALSE(contains(log, "internal error")) << log;
    }
}

TEST(Robustness, EglUnavailableFallsBackToOsmesaWithAWarning) {
    const auto dir = fresh_temp_dir("robust_egl");
    // glvnd finds no EGL vendor library: EGL cannot start, as on a machine without Mesa's EGL.
    const std::string no_egl = "__EGL_VENDOR_LIBRARY_FILENAMES=/nonexistent/egl.json ";
    std::string log;
    ASSERT_EQ(facesynth::testkit::run_command(no_egl + cli_path().string() + " render --size 32 --antialiasing none --quiet -o " + dir.string(), &log), 0) << log;
    EXPECT_TRUE(contains(log, "facesynth: warning: EGL unavailable")) << log;
    EXPECT_TRUE(contains(log, "rendering with OSMesa")) << log;
    EXPECT_EQ(read_json(dir / "render.json")["backend"], "osmesa");
    // Asking for EGL explicitly is an error, not a silent fallback.
    EXPECT_EQ(facesynth::testkit::run_command(no_egl + cli_path().string() + " render --backend egl --size 32 -o " + dir.string(), &log), 1) << log;
    EXPECT_TRUE(contains(log, "facesynth: error: EGL")) << log;
}

TEST(Robustness, NoOpenGlBackendIsAClearError) {
    const auto dir = fresh_temp_dir("robust_no_gl");
    // No EGL vendor, and a Gallium driver name OSMesa does not have (Mesa 22's OSMesa would crash).
    const std::string no_gl = "__EGL_VENDOR_LIBRARY_FILENAMES=/nonexistent/egl.json GALLIUM_DRIVER=nonexistent ";
    std::string log;
    EXPECT_EQ(facesynth::testkit::run_command(no_gl + cli_path().string() + " render --size 32 -o " + dir.string(), &log), 1) << log;
    EXPECT_TRUE(contains(log, "facesynth: error: render: no OpenGL backend available")) << log;
    EXPECT_TRUE(contains(log, "GALLIUM_DRIVER='nonexistent'")) << log;
    EXPECT_EQ(facesynth::testkit::run_command(no_gl + cli_path().string() + " synth -n 1 --size 32 --quiet -o " + (dir / "s").string(), &log), 1) << log;
    EXPECT_TRUE(contains(log, "no OpenGL backend available")) << log;
}

}  // namespace
