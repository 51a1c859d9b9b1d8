#include "synth/stream.h"

#include "core/error.h"
#include "morph/model_io.h"
#include "synth/texture_bank.h"
#include "synth/wallpapers.h"

#include <opencv2/core/utility.hpp>

#include <algorithm>

namespace facesynth::synth {

Appearance load_appearance(const SynthConfig& config, const morph::MorphableModel& model) {
    Appearance a;
    if (config.background.type == "images") a.backgrounds = ImageLibrary(config.background.folder, "background");
    if (config.background.type == "wallpapers") a.backgrounds = load_wallpaper_photos();
    if (!config.albedo.texture_folder.empty() || !config.albedo.texture_bank.empty()) {
        const std::string key = config.albedo.texture_bank.empty() ? "albedo.texture_folder" : "albedo.texture_bank";
        if (model.uv.cols() != model.num_vertices())
            throw core::Error(key + ": model '" + model.name + "' has no uv coordinates to map a texture with");
        a.textures = config.albedo.texture_bank.empty() ? ImageLibrary(config.albedo.texture_folder, "texture")
                                                        : load_texture_bank(config.albedo.texture_bank, model);
    }
    return a;
}

std::string distinct_renderers(const std::vector<std::string>& descriptions) {
    std::vector<std::string> distinct;
    std::string joined;
    for (const auto& name : descriptions)
        if (std::find(distinct.begin(), distinct.end(), name) == distinct.end()) {
            joined += (distinct.empty() ? "" : " + ") + name;
            distinct.push_back(name);
        }
    return joined;
}

OpenCvOnCallingThread::OpenCvOnCallingThread() : previous_(cv::getNumThreads()) { cv::setNumThreads(1); }
OpenCvOnCallingThread::~OpenCvOnCallingThread() { cv::setNumThreads(previous_); }

namespace {

SynthConfig validated(SynthConfig config) {
    validate(config);
    return config;
}

}  // namespace

SampleStream::SampleStream(SynthConfig config, int workers, const render::RendererOptions& renderer)
    : config_(validated(std::move(config))), owned_model_(morph::load_model(config_.model)), model_(*owned_model_),
      appearance_(load_appearance(config_, model_)) {
    start(workers, renderer);
}

SampleStream::SampleStream(SynthConfig config, const morph::MorphableModel& model, int workers, const render::RendererOptions& renderer)
    : config_(std::move(config)), model_(model), appearance_(load_appearance(config_, model_)) {
    start(workers, renderer);
}

void SampleStream::start(int workers, const render::RendererOptions& renderer) {
    if (workers < 1) throw core::Error("workers must be at least 1 (got " + std::to_string(workers) + ")");
    renderers_.resize(static_cast<std::size_t>(workers));
    times_.resize(static_cast<std::size_t>(workers));
    starting_ = workers;
    for (int w = 0; w < workers; ++w) {
        // Workers alternate between Mesa's two software displays: llvmpipe rasterises one scene at a
        // time per display, and two workers on one display waited for each other.
        render::RendererOptions options = renderer;
        options.software_display = renderer.software_display + w;
        threads_.emplace_back([this, w, options] { work(w, options); });
    }
    std::unique_lock lock(mutex_);
    wake_caller_.wait(lock, [this] { return starting_ == 0; });
    if (start_error_) {
        stopping_ = true;
        lock.unlock();
        wake_workers_.notify_all();
        for (auto& thread : threads_) thread.join();
        std::rethrow_exception(start_error_);
    }
}

SampleStream::~SampleStream() {
    {
        const std::lock_guard lock(mutex_);
        stopping_ = true;
    }
    wake_workers_.notify_all();
    for (auto& thread : threads_) thread.join();
}

std::string SampleStream::renderer_description() const { return distinct_renderers(renderers_); }

StageTimes SampleStream::times() const {
    const std::lock_guard lock(mutex_);
    StageTimes sum;
    for (const auto& t : times_) sum += t;
    return sum;
}

void SampleStream::work(int worker_index, render::RendererOptions renderer) {
    const auto worker = static_cast<std::size_t>(worker_index);
    std::unique_ptr<SampleGenerator> generator;
    {
        std::exception_ptr error;
        try {
            generator = std::make_unique<SampleGenerator>(config_, model_, appearance_.backgrounds, appearance_.textures, renderer);
            renderers_[worker] = generator->renderer_description();
        } catch (...) {
            error = std::current_exception();
        }
        const std::lock_guard lock(mutex_);
        if (error && !start_error_) start_error_ = error;
        --starting_;
    }
    wake_caller_.notify_all();
    std::uint64_t served = 0;
    for (;;) {
        {
            std::unique_lock lock(mutex_);
            wake_workers_.wait(lock, [&] { return stopping_ || generation_ != served; });
            if (stopping_) return;
            served = generation_;
        }
        std::size_t slot = 0;
        StageTimes times;
        while (take_slot(slot)) {
            const std::int64_t index = request_.indices[slot];
            try {
                Sample sample = generator->generate(index, &times);
                (*request_.consume)(worker_index, static_cast<std::int64_t>(slot), sample);
            } catch (const std::exception& e) {
                fail(std::make_exception_ptr(core::Error("sample " + sample_key(index) + ": " + e.what())));
            } catch (...) {
                fail(std::current_exception());
            }
        }
        {
            const std::lock_guard lock(mutex_);
            times_[worker] += times;
            --request_.running;
        }
        wake_caller_.notify_all();
    }
}

bool SampleStream::take_slot(std::size_t& slot) {
    const std::lock_guard lock(mutex_);
    if (request_.failed || request_.next >= request_.indices.size()) return false;
    slot = request_.next++;
    return true;
}

void SampleStream::fail(std::exception_ptr error) {
    const std::lock_guard lock(mutex_);
    request_.failed = true;
    if (!request_.first_error) request_.first_error = std::move(error);
}

void SampleStream::generate(std::span<const std::int64_t> indices, const Consumer& consume) {
    for (const std::int64_t index : indices)
        if (index < 0) throw core::Error("sample " + std::to_string(index) + ": indices must not be negative");
    if (indices.empty()) return;
    const std::lock_guard one_request(request_mutex_);
    const OpenCvOnCallingThread opencv_threads;
    std::unique_lock lock(mutex_);
    request_ = Request{indices, &consume, 0, workers(), false, nullptr};
    ++generation_;
    lock.unlock();
    wake_workers_.notify_all();
    lock.lock();
    wake_caller_.wait(lock, [this] { return request_.running == 0; });
    if (request_.first_error) std::rethrow_exception(request_.first_error);
}

void SampleStream::generate(std::int64_t start, std::int64_t count, const Consumer& consume) {
    if (start < 0 || count < 0)
        throw core::Error("samples " + std::to_string(start) + " + " + std::to_string(count) + ": start and count must not be negative");
    std::vector<std::int64_t> indices(static_cast<std::size_t>(count));
    for (std::size_t i = 0; i < indices.size(); ++i) indices[i] = start + static_cast<std::int64_t>(i);
    generate(indices, consume);
}

}  // namespace facesynth::synth
