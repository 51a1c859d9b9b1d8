#include "core/atomic_file.h"

#include "core/error.h"

#include <atomic>
#include <cerrno>
#include <cstring>
#include <fcntl.h>
#include <fstream>
#include <sstream>
#include <unistd.h>

namespace facesynth::core {
namespace {

std::string errno_text(int err) { return std::strerror(err); }

}  // namespace

std::filesystem::path temporary_path_for(const std::filesystem::path& path) {
    static std::atomic<unsigned> counter{0};
    auto temp = path;
    temp += ".tmp." + std::to_string(::getpid()) + "." + std::to_string(counter++);
    return temp;
}

void commit_temporary_file(const std::filesystem::path& temp, const std::filesystem::path& path) {
    // No fsync: the guarantee is against killed processes (the page cache survives SIGKILL), which
    // is what resumable jobs need, and an fsync per file would cost more than the render.
    if (std::rename(temp.c_str(), path.c_str()) != 0) {
        const int err = errno;
        std::error_code ignored;
        std::filesystem::remove(temp, ignored);
        throw file_error(path.string(), "cannot rename temporary file into place: " + errno_text(err));
    }
}

void write_file_atomically(const std::filesystem::path& path, std::string_view contents) {
    const auto temp = temporary_path_for(path);
    const int fd = ::open(temp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
    if (fd < 0) throw file_error(path.string(), "cannot create file: " + errno_text(errno));
    std::size_t written = 0;
    while (written < contents.size()) {
        const ssize_t n = ::write(fd, contents.data() + written, contents.size() - written);
        if (n < 0) {
            if (errno == EINTR) continue;
            const int err = errno;
            ::close(fd);
            ::unlink(temp.c_str());
            throw file_error(path.string(), "write failed: " + errno_text(err));
        }
        written += static_cast<std::size_t>(n);
    }
    if (::close(fd) != 0) {
        const int err = errno;
        ::unlink(temp.c_str());
        throw file_error(path.string(), "write failed: " + errno_text(err));
    }
    commit_temporary_file(temp, path);
}

std::string read_file(const std::filesystem::path& path) {
    std::ifstream in(path, std::ios::binary);
    if (!in) throw file_error(path.string(), std::string("cannot open: ") + errno_text(errno));
    std::ostringstream buffer;
    buffer << in.rdbuf();
    if (in.bad()) throw file_error(path.string(), "read failed");
    return buffer.str();
}

}  // namespace facesynth::core
