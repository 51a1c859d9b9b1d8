#pragma once
// Samples made in memory for a caller that consumes them directly (the Python module streams them
// into numpy arrays): sample i is the sample run_synth writes for the same config, with no files.
#include "morph/model.h"
#include "render/renderer.h"
#include "synth/config.h"
#include "synth/sample.h"

#include <condition_variable>
#include <cstdint>
#include <exception>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <span>
#include <string>
#include <thread>
#include <vector>

namespace facesynth::synth {

// The image folders a config draws from: backgrounds (background.type images or wallpapers) and
// texture maps (albedo.texture_folder or albedo.texture_bank). Throws core::Error naming the key and
// folder when one cannot be read.
struct Appearance {
    ImageLibrary backgrounds;
    ImageLibrary textures;
};
[[nodiscard]] Appearance load_appearance(const SynthConfig& config, const morph::MorphableModel& model);

// Each distinct renderer description once, joined by " + " (the workers' renderers, for reports).
[[nodiscard]] std::string distinct_renderers(const std::vector<std::string>& descriptions);

// While it lives, OpenCV runs its functions (the background blur, resizes) on the calling thread.
// Synth's workers already keep the cores busy; OpenCV's own thread pool only added hand-offs to
// pool threads (and CPU time outside the workers' stage clocks). The results are the same. OpenCV's
// setting is process-wide: the previous one is restored on destruction.
class OpenCvOnCallingThread {
public:
    OpenCvOnCallingThread();
    ~OpenCvOnCallingThread();
    OpenCvOnCallingThread(const OpenCvOnCallingThread&) = delete;
    OpenCvOnCallingThread& operator=(const OpenCvOnCallingThread&) = delete;
    OpenCvOnCallingThread(OpenCvOnCallingThread&&) = delete;
    OpenCvOnCallingThread& operator=(OpenCvOnCallingThread&&) = delete;

private:
    int previous_;
};

// A pool of worker threads, each with its own SampleGenerator (and so its own GL context, created
// once on that thread and used only there), that makes lists of samples on request: run_synth's
// workers, and the Python module's.
class SampleStream {
public:
    // Called from the worker threads, concurrently for different slots (positions in the request's
    // list of samples): `worker` (0 .. workers() - 1) tells which thread, for per-worker state; the
    // sample may be moved from.
    using Consumer = std::function<void(int worker, std::int64_t slot, Sample& sample)>;

    // Validates the config, loads config.model and the appearance folders, and starts `workers`
    // threads. Throws core::Error (the config key, file or renderer that failed) when any of that fails.
    SampleStream(SynthConfig config, int workers, const render::RendererOptions& renderer = {});
    // The same with a model the caller keeps alive (and has validated the config for).
    SampleStream(SynthConfig config, const morph::MorphableModel& model, int workers, const render::RendererOptions& renderer = {});
    ~SampleStream();
    SampleStream(const SampleStream&) = delete;
    SampleStream& operator=(const SampleStream&) = delete;
    SampleStream(SampleStream&&) = delete;
    SampleStream& operator=(SampleStream&&) = delete;

    // Makes the samples `indices` names (each >= 0), and hands each to `consume` with its position in
    // the list. Requests from several threads are served one after another. The first failure (a
    // sample's, or one thrown by `consume`) stops the workers and is rethrown as core::Error
    // "sample sNNNNNNNN: …" after all have stopped.
    void generate(std::span<const std::int64_t> indices, const Consumer& consume);
    // Samples start .. start + count - 1 (slot = index - start).
    void generate(std::int64_t start, std::int64_t count, const Consumer& consume);

    [[nodiscard]] const SynthConfig& config() const { return config_; }
    [[nodiscard]] const morph::MorphableModel& model() const { return model_; }
    [[nodiscard]] int workers() const { return static_cast<int>(threads_.size()); }
    // Each distinct renderer the workers use, joined by " + ".
    [[nodiscard]] std::string renderer_description() const;
    // The generators' stage times (sampling, render, composite), summed over workers and requests.
    [[nodiscard]] StageTimes times() const;

private:
    struct Request {
        std::span<const std::int64_t> indices;
        const Consumer* consume = nullptr;
        std::size_t next = 0;      // the next slot to take (guarded by mutex_)
        int running = 0;           // workers still on this request
        bool failed = false;
        std::exception_ptr first_error;
    };

    void start(int workers, const render::RendererOptions& renderer);
    void work(int worker_index, render::RendererOptions renderer);
    // Takes the next slot of the current request, or returns false when it has none left.
    bool take_slot(std::size_t& slot);
    void fail(std::exception_ptr error);

    const SynthConfig config_;
    std::optional<morph::MorphableModel> owned_model_;
    const morph::MorphableModel& model_;
    const Appearance appearance_;
    std::vector<std::string> renderers_;  // per worker, set when it has started
    std::vector<StageTimes> times_;       // per worker, written by that worker only while it works

    std::mutex request_mutex_;  // one request at a time
    mutable std::mutex mutex_;  // everything below
    std::condition_variable wake_workers_, wake_caller_;
    std::uint64_t generation_ = 0;  // bumped for each request
    Request request_;
    int starting_ = 0;   // workers still creating their generator
    bool stopping_ = false;
    std::exception_ptr start_error_;
    std::vector<std::thread> threads_;
};

}  // namespace facesynth::synth
