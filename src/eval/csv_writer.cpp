// CSV output for evaluation results.
#include "kestrel/eval/csv_writer.hpp"

#include <stdexcept>

#include "kestrel/core/error.hpp"
#include "kestrel/io/output_guard.hpp"
#include "kestrel/io/trajectory_io.hpp"

namespace kestrel::eval {

CsvWriter::CsvWriter(std::filesystem::path path, const std::vector<std::string>& columns,
                     std::string_view command, bool force)
    : path_(std::move(path)), columns_(columns.size()) {
  io::check_can_write_file(path_, command, force);
  out_.open(path_);
  if (!out_) throw InputError(path_.string() + ": cannot open file for writing");
  out_ << io::provenance_line(command) << "\n";
  for (std::size_t i = 0; i < columns.size(); ++i) out_ << (i > 0 ? "," : "") << columns[i];
  out_ << "\n";
}

void CsvWriter::separate() {
  if (in_row_ > 0) out_ << ',';
  ++in_row_;
}

CsvWriter& CsvWriter::add(double value) {
  separate();
  out_ << io::format_double(value);
  return *this;
}

CsvWriter& CsvWriter::add(std::int64_t value) {
  separate();
  out_ << value;
  return *this;
}

CsvWriter& CsvWriter::add(std::string_view text) {
  separate();
  if (text.find_first_of(",\"\r\n") == std::string_view::npos) {
    out_ << text;
    return *this;
  }
  out_ << '"';
  for (const char c : text) out_ << (c == '"' ? "\"\"" : std::string_view(&c, 1));
  out_ << '"';
  return *this;
}

void CsvWriter::end_row() {
  if (in_row_ != columns_) {
    throw std::logic_error("CsvWriter: row of " + std::to_string(in_row_) + " values for " +
                           std::to_string(columns_) + " columns in " + path_.string());
  }
  out_ << '\n';
  in_row_ = 0;
}

void CsvWriter::flush() { out_.flush(); }

void CsvWriter::close() {
  out_.flush();
  if (!out_) throw InputError(path_.string() + ": write failed (disk full?)");
  out_.close();
}

}  // namespace kestrel::eval
