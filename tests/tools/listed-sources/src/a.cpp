int listed_sources_a() {
  return 1;
}
