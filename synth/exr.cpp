#include "synth/exr.h"

#include "core/error.h"

#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfIO.h>
#include <OpenEXR/ImfOutputFile.h>

#include <cstdint>
#include <cstring>
#include <exception>

namespace facesynth::synth {
namespace {

// An OpenEXR output stream into a string: the writer seeks back to fill in the line offsets.
class StringOutputStream final : public Imf::OStream {
public:
    StringOutputStream() : Imf::OStream("depth.exr") {}
    void write(const char c[], int n) override {
        const auto count = static_cast<std::size_t>(n);
        if (position_ + count > bytes_.size()) bytes_.resize(position_ + count);
        std::memcpy(bytes_.data() + position_, c, count);
        position_ += count;
    }
    std::uint64_t tellp() override { return position_; }
    void seekp(std::uint64_t position) override { position_ = position; }
    [[nodiscard]] std::string take() { return std::move(bytes_); }

private:
    std::string bytes_;
    std::size_t position_ = 0;
};

}  // namespace

std::string encode_depth_exr(const cv::Mat& depth, const std::string& context) {
    if (depth.type() != CV_32FC1 || !depth.isContinuous()) throw core::Error(context + ": depth map must be a continuous CV_32FC1 image");
    if (depth.empty()) throw core::Error(context + ": depth map is empty");
    StringOutputStream stream;
    try {
        // No time stamp (capDate) unless one is added: sample i's file is the same bytes in every run.
        Imf::Header header(depth.cols, depth.rows);
        header.compression() = Imf::ZIP_COMPRESSION;
        header.channels().insert("Z", Imf::Channel(Imf::FLOAT));
        Imf::FrameBuffer frame;
        // OpenEXR's slices take a non-const base pointer but only read from it when writing.
        auto* base = const_cast<char*>(reinterpret_cast<const char*>(depth.ptr<float>()));  // NOLINT(cppcoreguidelines-pro-type-const-cast)
        frame.insert("Z", Imf::Slice(Imf::FLOAT, base, sizeof(float), sizeof(float) * static_cast<std::size_t>(depth.cols)));
        Imf::OutputFile file(stream, header, 0);  // 0: compressed on this thread (samples run on workers already)
        file.setFrameBuffer(frame);
        file.writePixels(depth.rows);
    } catch (const std::exception& e) {
        throw core::Error(context + ": EXR encoding failed: " + e.what());
    }
    return stream.take();
}

}  // namespace facesynth::synth
