fn main() {
    println!("spincal");
}
