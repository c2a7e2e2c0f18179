mod compare;

fn main() {}
