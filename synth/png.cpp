#include "synth/png.h"

#include "core/error.h"

#include <libdeflate.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <string_view>

namespace facesynth::synth {
namespace {

constexpr unsigned char kFilterNone = 0;
constexpr unsigned char kFilterUp = 2;
// IDAT chunks are limited to 2^31 - 1 bytes; larger streams are split over several.
constexpr std::size_t kMaxChunk = std::size_t{1} << 30;

void append_be32(std::string& out, std::uint32_t value) {
    const char bytes[4] = {static_cast<char>(value >> 24), static_cast<char>(value >> 16), static_cast<char>(value >> 8),
                           static_cast<char>(value)};
    out.append(bytes, 4);
}

// length, type, data, CRC-32 of type and data.
void append_chunk(std::string& out, std::string_view type, const unsigned char* data, std::size_t size) {
    append_be32(out, static_cast<std::uint32_t>(size));
    const std::size_t crc_start = out.size();
    out.append(type);
    if (size > 0) out.append(reinterpret_cast<const char*>(data), size);
    const auto crc = libdeflate_crc32(0, out.data() + crc_start, out.size() - crc_start);
    append_be32(out, crc);
}

}  // namespace

void PngEncoder::FreeCompressor::operator()(libdeflate_compressor* compressor) const { libdeflate_free_compressor(compressor); }

PngEncoder::PngEncoder(int level) : level_(level) {
    if (level < 0 || level > 9) throw core::Error("PNG compression level " + std::to_string(level) + " is outside 0-9");
    compressor_.reset(libdeflate_alloc_compressor(level));
    if (!compressor_) throw core::Error("PNG encoder: cannot allocate a deflate compressor (out of memory?)");
}

PngEncoder::~PngEncoder() = default;
PngEncoder::PngEncoder(PngEncoder&&) noexcept = default;
PngEncoder& PngEncoder::operator=(PngEncoder&&) noexcept = default;

std::string PngEncoder::encode(const cv::Mat& image, const std::string& context) {
    if (image.empty() || (image.type() != CV_8UC1 && image.type() != CV_8UC3))
        throw core::Error(context + ": PNG encoding needs a non-empty 8-bit grey or RGB image");
    const int channels = image.channels();
    const auto row_bytes = static_cast<std::size_t>(image.cols) * static_cast<std::size_t>(channels);
    // Stored (level 0) rows gain nothing from a filter.
    const unsigned char filter = level_ == 0 ? kFilterNone : kFilterUp;
    filtered_.resize((row_bytes + 1) * static_cast<std::size_t>(image.rows));
    for (int y = 0; y < image.rows; ++y) {
        unsigned char* out = filtered_.data() + (row_bytes + 1) * static_cast<std::size_t>(y);
        const unsigned char* row = image.ptr<unsigned char>(y);
        *out++ = filter;
        if (filter == kFilterNone || y == 0) {  // Up with the zero row above the image is the row itself
            std::memcpy(out, row, row_bytes);
        } else {
            const unsigned char* above = image.ptr<unsigned char>(y - 1);
            for (std::size_t i = 0; i < row_bytes; ++i) out[i] = static_cast<unsigned char>(row[i] - above[i]);
        }
    }
    deflated_.resize(libdeflate_zlib_compress_bound(compressor_.get(), filtered_.size()));
    const std::size_t deflated_size =
        libdeflate_zlib_compress(compressor_.get(), filtered_.data(), filtered_.size(), deflated_.data(), deflated_.size());
    if (deflated_size == 0) throw core::Error(context + ": PNG compression failed");

    std::string png;
    png.reserve(deflated_size + 64 + 12 * (deflated_size / kMaxChunk));
    png.append("\x89PNG\r\n\x1a\n", 8);
    unsigned char header[13] = {};
    const auto put_be32 = [](unsigned char* p, std::uint32_t v) {
        p[0] = static_cast<unsigned char>(v >> 24), p[1] = static_cast<unsigned char>(v >> 16);
        p[2] = static_cast<unsigned char>(v >> 8), p[3] = static_cast<unsigned char>(v);
    };
    put_be32(header, static_cast<std::uint32_t>(image.cols));
    put_be32(header + 4, static_cast<std::uint32_t>(image.rows));
    header[8] = 8;                          // bits per channel
    header[9] = channels == 3 ? 2 : 0;      // colour type: RGB or grey
    // header[10..12]: deflate compression, adaptive filtering (per-row filter bytes), no interlace: 0
    append_chunk(png, "IHDR", header, sizeof header);
    for (std::size_t start = 0; start < deflated_size; start += kMaxChunk)
        append_chunk(png, "IDAT", deflated_.data() + start, std::min(kMaxChunk, deflated_size - start));
    append_chunk(png, "IEND", nullptr, 0);
    return png;
}

std::string encode_image(const cv::Mat& rgb, std::string_view format, int jpeg_quality, PngEncoder& png, const std::string& context) {
    if (format != "jpg") return png.encode(rgb, context);
    cv::Mat bgr;
    cv::cvtColor(rgb, bgr, cv::COLOR_RGB2BGR);
    std::vector<uchar> bytes;
    if (!cv::imencode(".jpg", bgr, bytes, {cv::IMWRITE_JPEG_QUALITY, jpeg_quality})) throw core::Error(context + ": image encoding failed");
    return {bytes.begin(), bytes.end()};
}

}  // namespace facesynth::synth
