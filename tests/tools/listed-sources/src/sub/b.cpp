int listed_sources_b() {
  return 2;
}
