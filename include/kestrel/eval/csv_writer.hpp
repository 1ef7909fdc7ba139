// Writing evaluation results as CSV: Kestrel's provenance line, a header row with units in
// the column names, and numbers that read back exactly.
#pragma once

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>
#include <string_view>
#include <vector>

namespace kestrel::eval {

class CsvWriter {
 public:
  /// Checks that `path` may be written (io::check_can_write_file), writes the provenance
  /// line of `command` and the header. Throws InputError naming the file.
  CsvWriter(std::filesystem::path path, const std::vector<std::string>& columns,
            std::string_view command, bool force);

  CsvWriter& add(double value);
  CsvWriter& add(std::int64_t value);
  /// A text cell; quoted (RFC 4180, inner quotes doubled) when it holds a comma, quote or
  /// line break.
  CsvWriter& add(std::string_view text);
  /// Ends the row; throws std::logic_error if it does not have one value per column.
  void end_row();
  /// Pushes the rows ended so far to the file (a log that is read while it grows).
  void flush();
  /// Flushes; throws InputError if anything failed to write.
  void close();

 private:
  void separate();

  std::filesystem::path path_;
  std::ofstream out_;
  std::size_t columns_ = 0;
  std::size_t in_row_ = 0;
};

}  // namespace kestrel::eval
