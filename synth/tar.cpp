#include "synth/tar.h"

#include "core/atomic_file.h"
#include "core/error.h"

#include <archive.h>
#include <archive_entry.h>

#include <memory>

namespace facesynth::synth {
namespace {

struct ArchiveWriter {
    archive* a = archive_write_new();
    ~ArchiveWriter() { archive_write_free(a); }
};
struct ArchiveReader {
    archive* a = archive_read_new();
    ~ArchiveReader() { archive_read_free(a); }
};
struct Entry {
    archive_entry* e = archive_entry_new();
    ~Entry() { archive_entry_free(e); }
};

}  // namespace

void write_tar_file(const std::filesystem::path& path, const std::vector<TarMember>& members) {
    const auto temp = core::temporary_path_for(path);
    {
        ArchiveWriter writer;
        // POSIX ustar: no pax extended headers (which would carry times), names up to 100 bytes.
        if (archive_write_set_format_ustar(writer.a) != ARCHIVE_OK || archive_write_open_filename(writer.a, temp.c_str()) != ARCHIVE_OK)
            throw core::file_error(path.string(), std::string("cannot create tar: ") + archive_error_string(writer.a));
        const auto fail = [&](const std::string& what) {
            const std::string message = what + ": " + (archive_error_string(writer.a) ? archive_error_string(writer.a) : "unknown error");
            std::filesystem::remove(temp);
            return core::file_error(path.string(), message);
        };
        for (const auto& member : members) {
            const std::string bytes = core::read_file(member.source);
            Entry entry;
            archive_entry_set_pathname(entry.e, member.name.c_str());
            archive_entry_set_size(entry.e, static_cast<la_int64_t>(bytes.size()));
            archive_entry_set_filetype(entry.e, AE_IFREG);
            archive_entry_set_perm(entry.e, 0644);
            archive_entry_set_mtime(entry.e, 0, 0);
            archive_entry_set_uid(entry.e, 0);
            archive_entry_set_gid(entry.e, 0);
            if (archive_write_header(writer.a, entry.e) != ARCHIVE_OK) throw fail("member " + member.name);
            if (archive_write_data(writer.a, bytes.data(), bytes.size()) != static_cast<la_ssize_t>(bytes.size()))
                throw fail("member " + member.name + " (disk full?)");
        }
        if (archive_write_close(writer.a) != ARCHIVE_OK) throw fail("closing");
    }
    core::commit_temporary_file(temp, path);
}

std::vector<TarEntry> list_tar(const std::filesystem::path& path) {
    ArchiveReader reader;
    archive_read_support_format_tar(reader.a);
    if (archive_read_open_filename(reader.a, path.c_str(), 1 << 16) != ARCHIVE_OK)
        throw core::file_error(path.string(), std::string("cannot open tar: ") + archive_error_string(reader.a));
    std::vector<TarEntry> entries;
    archive_entry* entry = nullptr;
    int status = ARCHIVE_OK;
    while ((status = archive_read_next_header(reader.a, &entry)) == ARCHIVE_OK) {
        entries.push_back({archive_entry_pathname(entry), static_cast<std::size_t>(archive_entry_size(entry))});
        archive_read_data_skip(reader.a);
    }
    if (status != ARCHIVE_EOF) throw core::file_error(path.string(), std::string("corrupt tar: ") + archive_error_string(reader.a));
    return entries;
}

}  // namespace facesynth::synth
