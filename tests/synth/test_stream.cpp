// synth's SampleStream (what the Python module streams from): the samples a SampleGenerator makes,
// whatever the number of workers, with failures named by sample and requests from several threads.
#include "core/error.h"
#include "morph/model_io.h"
#include "render/renderer.h"
#include "synth/config.h"
#include "synth/stream.h"
#include "common/test_data.h"

#include <gtest/gtest.h>

#include <opencv2/core.hpp>

#include <mutex>
#include <thread>

namespace facesynth::synth {
namespace {

SynthConfig small_stream_config() {
    SynthConfig config;
    config.camera.width = config.camera.height = 64;
    config.output.mask = true;
    return config;
}

const render::RendererOptions kStreamRenderer{render::Backend::kEgl, false};

bool identical_pixels(const cv::Mat& a, const cv::Mat& b) {
    return a.size() == b.size() && a.type() == b.type() && cv::norm(a, b, cv::NORM_INF) == 0;
}

// Samples start .. start + count - 1 of `stream`, by slot.
std::vector<Sample> stream_samples(SampleStream& stream, std::int64_t start, std::int64_t count) {
    std::vector<Sample> samples(static_cast<std::size_t>(count));
    stream.generate(start, count, [&](int, std::int64_t slot, Sample& s) { samples[static_cast<std::size_t>(slot)] = std::move(s); });
    return samples;
}

TEST(SampleStream, MakesTheGeneratorsSamplesWithAnyNumberOfWorkers) {
    const SynthConfig config = small_stream_config();
    const morph::MorphableModel model = morph::load_model(config.model);
    const ImageLibrary none;
    SampleGenerator reference(config, model, none, none, kStreamRenderer);
    SampleStream one(config, 1, kStreamRenderer), three(config, 3, kStreamRenderer);
    EXPECT_EQ(three.workers(), 3);
    EXPECT_FALSE(three.renderer_description().empty());
    const auto a = stream_samples(one, 2, 5), b = stream_samples(three, 2, 5);
    for (std::int64_t slot = 0; slot < 5; ++slot) {
        const Sample expected = reference.generate(2 + slot);
        for (const auto* got : {&a[static_cast<std::size_t>(slot)], &b[static_cast<std::size_t>(slot)]}) {
            EXPECT_EQ(got->spec.index, 2 + slot);
            EXPECT_TRUE(identical_pixels(got->image, expected.image)) << "slot " << slot;
            EXPECT_TRUE(identical_pixels(got->mask, expected.mask)) << "slot " << slot;
            EXPECT_EQ(got->labels.landmarks_contour, expected.labels.landmarks_contour) << "slot " << slot;
        }
    }
    // Requests after the first reuse the same workers; an empty request makes nothing.
    const auto again = stream_samples(three, 4, 1);
    EXPECT_TRUE(identical_pixels(again[0].image, a[2].image));
    int calls = 0;
    three.generate(7, 0, [&](int, std::int64_t, Sample&) { ++calls; });
    EXPECT_EQ(calls, 0);
}

TEST(SampleStream, MakesAListOfSamplesInAnyOrderAndCountsItsTime) {
    const SynthConfig config = small_stream_config();
    SampleStream stream(config, 2, kStreamRenderer);
    const std::vector<std::int64_t> indices{9, 2, 5};
    std::vector<Sample> samples(indices.size());
    std::mutex mutex;
    std::vector<int> workers_seen;
    stream.generate(indices, [&](int worker, std::int64_t slot, Sample& s) {
        samples[static_cast<std::size_t>(slot)] = std::move(s);
        const std::lock_guard lock(mutex);
        workers_seen.push_back(worker);
    });
    const auto in_order = stream_samples(stream, 2, 8);
    for (std::size_t i = 0; i < indices.size(); ++i) {
        EXPECT_EQ(samples[i].spec.index, indices[i]);
        EXPECT_TRUE(identical_pixels(samples[i].image, in_order[static_cast<std::size_t>(indices[i] - 2)].image));
    }
    for (const int worker : workers_seen) EXPECT_TRUE(worker == 0 || worker == 1) << worker;
    EXPECT_GT(stream.times().render.wall, 0);
    EXPECT_NE(testkit::error_message_of([&] {
                  const std::vector<std::int64_t> negative{3, -2};
                  stream.generate(negative, [](int, std::int64_t, Sample&) {});
              }).find("must not be negative"),
              std::string::npos);
}

TEST(SampleStream, AFailureNamesTheSampleAndTheStreamKeepsWorking) {
    SampleStream stream(small_stream_config(), 2, kStreamRenderer);
    const std::string message = testkit::error_message_of([&] {
        stream.generate(10, 4, [](int, std::int64_t slot, Sample&) {
            if (slot == 2) throw core::Error("no room for it");
        });
    });
    EXPECT_NE(message.find("sample s00000012: no room for it"), std::string::npos) << message;
    EXPECT_EQ(stream_samples(stream, 10, 3).size(), 3U);
    EXPECT_NE(testkit::error_message_of([&] { stream.generate(-1, 2, [](int, std::int64_t, Sample&) {}); }).find("must not be negative"),
              std::string::npos);
}

TEST(SampleStream, RequestsFromTwoThreadsAreServedOneAfterAnother) {
    SampleStream stream(small_stream_config(), 2, kStreamRenderer);
    const auto expected = stream_samples(stream, 0, 3);
    std::vector<std::vector<Sample>> results(2);
    std::vector<std::thread> callers;
    for (std::size_t t = 0; t < 2; ++t) callers.emplace_back([&, t] { results[t] = stream_samples(stream, 0, 3); });
    for (auto& caller : callers) caller.join();
    for (const auto& samples : results)
        for (std::size_t i = 0; i < 3; ++i) EXPECT_TRUE(identical_pixels(samples[i].image, expected[i].image));
}

TEST(SampleStream, BadConfigModelOrWorkerCountFailsWithTheReason) {
    SynthConfig bad_key = small_stream_config();
    bad_key.pose.yaw.min = 10;
    bad_key.pose.yaw.max = 5;
    EXPECT_NE(testkit::error_message_of([&] { SampleStream s(bad_key, 1, kStreamRenderer); }).find("pose.yaw.min"), std::string::npos);
    SynthConfig bad_model = small_stream_config();
    bad_model.model = "/nonexistent/model.fsm";
    EXPECT_NE(testkit::error_message_of([&] { SampleStream s(bad_model, 1, kStreamRenderer); }).find("/nonexistent/model.fsm"), std::string::npos);
    EXPECT_NE(testkit::error_message_of([&] { SampleStream s(small_stream_config(), 0, kStreamRenderer); }).find("workers"), std::string::npos);
}

TEST(SynthSettings, ProgramValuesFollowTomlTypesAndNameTheKey) {
    SynthConfig config;
    apply_settings(config, nlohmann::json::parse(R"({"pose": {"yaw": {"max": 40}}, "camera.width": 80, "output.mask": true, "lighting.white_balance": 1})"), "config");
    EXPECT_EQ(config.pose.yaw.max, 40);
    EXPECT_EQ(config.camera.width, 80);
    EXPECT_TRUE(config.output.mask);
    EXPECT_EQ(config.lighting.white_balance, 1.0);
    const auto message_for = [](const char* json) {
        return testkit::error_message_of([&] {
            SynthConfig c;
            apply_settings(c, nlohmann::json::parse(json), "config");
        });
    };
    EXPECT_EQ(message_for(R"({"pose": {"yaw": {"maxx": 1}}})").rfind("config: ", 0), 0U);
    EXPECT_NE(message_for(R"({"pose": {"yaw": {"maxx": 1}}})").find("pose.yaw.maxx"), std::string::npos);
    EXPECT_NE(message_for(R"({"camera.width": 1.5})").find("'camera.width' must be"), std::string::npos);
    EXPECT_NE(message_for(R"({"seed": "x"})").find("'seed' must be"), std::string::npos);
    EXPECT_NE(message_for(R"({"seed": -1})").find("'seed' must be"), std::string::npos);
    EXPECT_NE(message_for(R"({"identity": [1]})").find("'identity' must be a number, boolean or string"), std::string::npos);
    EXPECT_NE(message_for(R"([1])").find("must be a mapping"), std::string::npos);
}

}  // namespace
}  // namespace facesynth::synth
