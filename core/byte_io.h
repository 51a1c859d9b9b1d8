#pragma once
// Little-endian binary reading and writing shared by the model file formats. The reader checks
// every size against the bytes that remain before anything is allocated, and every failure names
// the file, the field and the byte offset.
#include "core/error.h"

#include <Eigen/Core>

#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <string>
#include <string_view>
#include <type_traits>

namespace facesynth::core {

static_assert(std::endian::native == std::endian::little, "model files are little-endian; add byte swapping");

class ByteReader {
public:
    ByteReader(std::string_view bytes, std::string path) : bytes_(bytes), path_(std::move(path)) {}

    [[nodiscard]] std::size_t remaining() const { return bytes_.size() - offset_; }
    [[nodiscard]] std::size_t offset() const { return offset_; }
    [[nodiscard]] const std::string& path() const { return path_; }
    [[nodiscard]] bool at_end() const { return offset_ == bytes_.size(); }

    [[nodiscard]] Error error(const std::string& problem) const {
        return file_error(path_, problem + " (at byte " + std::to_string(offset_) + ")");
    }

    template <typename T>
    T read(const char* what) {
        static_assert(std::is_trivially_copyable_v<T>);
        require(sizeof(T), what);
        T value;
        std::memcpy(&value, bytes_.data() + offset_, sizeof(T));
        offset_ += sizeof(T);
        return value;
    }

    // A count of elements of `element_size` bytes each that must still fit in the file.
    std::size_t read_count(std::size_t element_size, const char* what) {
        const auto count = read<std::uint64_t>(what);
        check_fits(count, element_size, what);
        return static_cast<std::size_t>(count);
    }

    void check_fits(std::uint64_t count, std::size_t element_size, const char* what) const {
        if (element_size != 0 && count > remaining() / element_size)
            throw error(std::string(what) + ": size " + std::to_string(count) + " exceeds the " +
                        std::to_string(remaining()) + " bytes left in the file (truncated or corrupt)");
    }

    void read_bytes(void* out, std::size_t size, const char* what) {
        require(size, what);
        if (size) std::memcpy(out, bytes_.data() + offset_, size);
        offset_ += size;
    }

    void skip(std::size_t size, const char* what) {
        require(size, what);
        offset_ += size;
    }

    std::string read_string(const char* what) {
        const std::size_t n = read_count(1, what);
        std::string s(bytes_.substr(offset_, n));
        offset_ += n;
        return s;
    }

    // Finite float32 values into `out` (already sized).
    template <typename Derived>
    void read_floats(Eigen::PlainObjectBase<Derived>& out, const char* what) {
        static_assert(std::is_same_v<typename Derived::Scalar, float>);
        const std::size_t offset_before = offset_;
        read_bytes(out.data(), sizeof(float) * static_cast<std::size_t>(out.size()), what);
        if (out.size() && !out.allFinite()) {
            offset_ = offset_before;
            throw error(std::string(what) + " contains NaN or infinite values");
        }
    }

private:
    void require(std::size_t size, const char* what) const {
        if (size > remaining())
            throw error(std::string(what) + ": file ends after " + std::to_string(bytes_.size()) +
                        " bytes (truncated)");
    }

    std::string_view bytes_;
    std::string path_;
    std::size_t offset_ = 0;
};

class ByteWriter {
public:
    template <typename T>
    void write(const T& value) {
        static_assert(std::is_trivially_copyable_v<T>);
        bytes_.append(reinterpret_cast<const char*>(&value), sizeof(T));
    }
    void write_bytes(const void* data, std::size_t size) {
        if (size) bytes_.append(static_cast<const char*>(data), size);
    }
    void write_string(std::string_view s) {
        write(static_cast<std::uint64_t>(s.size()));
        bytes_.append(s);
    }
    template <typename Derived>
    void write_floats(const Eigen::DenseBase<Derived>& m) {
        const Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic> plain = m;
        write_bytes(plain.data(), sizeof(float) * static_cast<std::size_t>(plain.size()));
    }
    [[nodiscard]] const std::string& bytes() const { return bytes_; }
    [[nodiscard]] std::string& bytes() { return bytes_; }

private:
    std::string bytes_;
};

}  // namespace facesynth::core
